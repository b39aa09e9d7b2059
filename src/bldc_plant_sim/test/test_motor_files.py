"""Motor data files: parameter semantics pinned against the seeds' rated values."""
from __future__ import annotations

import math

import numpy as np
import pytest

from bldc_plant_sim.core.motor import Motor
from bldc_plant_sim.core.plant import PlantCore
from bldc_plant_sim.parameters import load_motor_file, plant_params
from plant_test_helpers import bldc_params


def test_ozturk_lambda_f_is_the_line_to_line_constant_per_electrical_rad_s():
    p = plant_params('ozturk_bldc')
    motor = Motor.from_params(p)
    assert motor.pole_pairs == 2 and motor.inductance == pytest.approx(1.4e-3 - 0.3125e-3)
    # two-phase conduction on the flat tops (theta_e = 90 deg: k_a = -K, k_b = +K): T = 2 p K I
    i_rated = 5.6
    torque = motor.torque(math.radians(90), (-i_rated, i_rated, 0.0))
    assert torque == pytest.approx(1.28352, rel=1e-9)            # 000 App. A rated torque
    assert motor.backemf.line_to_line_peak() == pytest.approx(0.1146, rel=1e-12)   # = lambda_f


def _simulated_torque_at(i_target: float, constant: float) -> tuple[float, float]:
    """(T_e, i_b) once the b+ a- current of the locked 000 motor has risen to i_target,
    with the phase flat-top constant K = constant (the reading of lambda_f under test)."""
    p = bldc_params(**{'load.mode': 'dynamometer', 'load.speed': 0.0,
                       'motor.initial_angle': math.radians(45),       # theta_e = 90 deg: flat tops
                       'motor.backemf.constant': constant})
    plant = PlantCore(p)
    plant.apply_gates((False, True, True, False, False, False))      # b+ a-: i_b = -i_a > 0
    # V_dc / (2 (L - M)) = 26 kA/s: about 9 ticks to 5.6 A; the bound only guards a broken plant
    for _ in range(200):
        if plant.i[1] >= i_target:
            break
        plant.advance()
    s = plant.state()
    assert s.phase_current[1] >= i_target, 'current never reached the target'
    return s.electromagnetic_torque, s.phase_current[1]


def test_ozturk_rated_torque_is_produced_in_the_simulation():
    torque, i_b = _simulated_torque_at(5.6, 0.0573)
    assert torque == pytest.approx(2 * 2 * 0.0573 * i_b, rel=1e-9)
    assert torque * 5.6 / i_b == pytest.approx(1.28352, rel=1e-9)    # rated torque at 5.6 A


@pytest.mark.parametrize('reading, constant, ratio', [
    ('lambda_f as the phase constant per electrical rad/s', 0.1146, 2.0),
    ('lambda_f as the line-to-line constant per mechanical rad/s', 0.1146 / 2 / 2, 0.5),
])
def test_the_rejected_readings_of_lambda_f_miss_the_rated_torque_by_two(reading, constant, ratio):
    # Simulate the plant with each alternative reading of 000 App. A's lambda_f = 0.1146 Wb:
    # at the rated 5.6 A it makes ratio x the rated 1.28352 N m, so only K = lambda_f / p fits.
    torque, i_b = _simulated_torque_at(5.6, constant)
    rated, i_rated = _simulated_torque_at(5.6, 0.0573)
    assert torque * 5.6 / i_b == pytest.approx(ratio * 1.28352, rel=1e-9), reading
    assert (torque / i_b) / (rated / i_rated) == pytest.approx(ratio, rel=1e-9), reading


def test_fstp_machine_rated_torque_and_table_vii_imbalance():
    p = plant_params('fstp_pm_blac')
    motor = Motor.from_params(p)
    assert motor.inductance == pytest.approx(3.19e-3) and motor.resistance == 0.466
    # q-axis current of 2.2 A peak (i_x in phase with -k_x fundamental): T = 3/2 p psi I
    th = np.linspace(0, 2 * math.pi, 360, endpoint=False)
    torques = [motor.torque(t, tuple(-2.2 * math.sin(t - s) for s in (0, 2 * math.pi / 3, 4 * math.pi / 3)))
               for t in th]
    assert np.mean(torques) == pytest.approx(0.3, rel=0.03)       # Table VIII: 0.3 N m at 2.2 A
    # Table VII fundamentals at 1500 rpm, relative to each other
    fund = motor.backemf.fundamental * (1500 * 2 * math.pi / 60)
    table_vii = np.array([14.0868, 14.2880, 14.4254])
    np.testing.assert_allclose(fund / fund.mean(), table_vii / table_vii.mean(), rtol=1e-4)


def test_motor_files_hold_only_motor_data_and_document_assumptions():
    for name in ('ozturk_bldc', 'ozturk_bldc_nonideal', 'fstp_pm_blac'):
        values = load_motor_file(name)
        assert {'motor.inertia', 'motor.friction'} <= set(values)
        text = load_motor_file.__globals__['motor_file_path'](name).read_text()
        assert 'Assumed' in text or 'assumptions' in text
