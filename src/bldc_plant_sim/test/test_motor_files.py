"""Motor data files: parameter semantics pinned against the seeds' rated values."""
from __future__ import annotations

import math

import numpy as np
import pytest

from bldc_plant_sim.core.motor import Motor
from bldc_plant_sim.core.plant import PlantCore
from bldc_plant_sim.parameters import load_motor_file, plant_params


def test_ozturk_lambda_f_is_the_line_to_line_constant_per_electrical_rad_s():
    p = plant_params('ozturk_bldc')
    motor = Motor.from_params(p)
    assert motor.pole_pairs == 2 and motor.inductance == pytest.approx(1.4e-3 - 0.3125e-3)
    # two-phase conduction on the flat tops (theta_e = 90 deg: k_a = -K, k_b = +K): T = 2 p K I
    i_rated = 5.6
    torque = motor.torque(math.radians(90), (-i_rated, i_rated, 0.0))
    assert torque == pytest.approx(1.28352, rel=1e-9)            # 000 App. A rated torque
    assert motor.backemf.line_to_line_peak() == pytest.approx(0.1146, rel=1e-12)   # = lambda_f
    # the rejected readings miss the rating by a factor of two
    assert p['motor.backemf.constant'] == pytest.approx(0.1146 / 2)
    phase_per_electrical = 2 * 2 * 0.1146 * i_rated            # K = lambda_f
    line_per_mechanical = 2 * 2 * (0.1146 / 2 / 2) * i_rated    # k_LL = lambda_f per mech rad/s
    assert phase_per_electrical == pytest.approx(2 * 1.28352, rel=1e-4)
    assert line_per_mechanical == pytest.approx(1.28352 / 2, rel=1e-4)


def test_ozturk_rated_torque_is_produced_in_the_simulation():
    # dynamometer at low speed, six-step on the flat top, current held near 5.6 A by the supply
    p = plant_params('ozturk_bldc', **{'load.mode': 'dynamometer', 'load.speed': 0.0,
                                       'motor.initial_angle': math.radians(45)})    # theta_e = 90 deg
    plant = PlantCore(p)
    plant.apply_gates((False, True, True, False, False, False))   # b+ a-: i_b = -i_a > 0
    while plant.i[1] < 5.6:
        plant.advance()
    s = plant.state()
    assert s.electromagnetic_torque == pytest.approx(2 * 2 * 0.0573 * s.phase_current[1], rel=1e-9)


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
