import math

import numpy as np
import pytest

from drive_common.samples import DriveSample
from dtc_controller.core.controller import DtcCore
from dtc_controller.core.modes import two_phase_kernel as K
from dtc_controller.core.speed_loop import speed_pi_update
from dtc_controller.core.stator_flux_estimators import trapezoid_flux_step
from dtc_controller.core.vectors import leg_states
from dtc_controller.core import position as pos
from drive_common.signals import clarke


def test_torque_eq_2_16_equals_phase_sum(trap_table):
    """The two-phase modes' torque estimate (eq. 2.16/4.1) is the phase sum of eq. (4.4), p sum k_x i_x."""
    core = DtcCore({'motor.pole_pairs': 2}, trap_table)
    for step, th in enumerate((0.1, 1.0, 2.5, 4.0, 5.9)):
        i = (3.0, -1.0, -2.0)
        total = core.update(DriveSample(step, 0.0, i, 56.6, 28.3, 0, th, 0, 0.0))[1].torque_estimate
        k = trap_table.k_abc(th)
        assert total == pytest.approx(2 * sum(kx * ix for kx, ix in zip(k, i)), rel=1e-9)
    # two-phase flat-top: T = p (k_b - k_c) I = 2 * 2K * I in sector 1 (b+, c-)
    k = trap_table.k_abc(0.0)
    st = core.update(DriveSample(9, 0.0, (0.0, 5.0, -5.0), 56.6, 28.3, 0, 0.0, 0, 0.0))[1]
    assert st.torque_estimate == pytest.approx(2 * (k[1] - k[2]) * 5.0)


def test_flux_integrator_eq_1_22_trapezoidal_current():
    psi = trapezoid_flux_step(0.1, 0.0, 10.0, -2.0, 0.5, 1e-4, 1.0, 0.0, 3.0, 1.0)
    assert psi == pytest.approx((0.1 + (10.0 - 0.5 * 2.0) * 1e-4, (-2.0 - 0.5 * 0.5) * 1e-4))


def voltage(sw, i, diode=False, emf=None):
    """(v_alpha, v_beta) [V] of switch state sw at v_dc = 100 V, v_mid = 50 V by the kernels' voltage model."""
    legs = np.array([K.LEG_CODES[leg] for leg in leg_states(sw, None)], dtype=np.int64)
    e = emf or (0.0, 0.0, 0.0)
    return K.applied_voltage(K.coefficient_table(), legs, diode, 0.05, 100.0, 50.0, *i, emf is not None, *e)


def test_voltage_model_diode_clamp():
    sw = (True, False, False, False, False, True)  # V1: a+, c-, b open
    i = (5.0, 2.0, -7.0)  # b still carries 2 A into the motor: its lower diode clamps it to 0 V
    v_ideal = voltage(sw, i)
    assert v_ideal == pytest.approx((50.0, 50.0 / math.sqrt(3)))
    # terminals a = 100, b = c = 0 -> three-phase vector (2/3 * 100 - ..., ...)
    assert voltage(sw, i, diode=True) == pytest.approx(clarke(100 - 100 / 3, -100 / 3, -100 / 3))
    assert voltage(sw, (5.0, 0.0, -5.0), diode=True) == pytest.approx(v_ideal)
    # open-phase back-EMF bends the vector along the b axis (curved flux locus)
    va, vb = voltage(sw, i, emf=(0.0, 10.0, 0.0))
    assert (va - v_ideal[0], vb - v_ideal[1]) == pytest.approx((-5.0, 10.0 * math.sqrt(3) / 2))


def test_speed_pi_runs_every_n_and_antiwindup():
    def run(calls, kp=0.1, ki=10.0, every_n=4, state=(0.0, 0.0, 0)):
        outs = []
        for ref, speed in calls:
            state = speed_pi_update(kp, ki, every_n, 1e-4, 1.0, *state, ref, speed)
            outs.append(state[1])
        return outs, state
    outs, _ = run([(1.0, 0.0)] * 8)
    assert outs[0] == outs[1] == outs[2] == outs[3] and outs[4] != outs[3]
    assert outs[0] == pytest.approx(0.1 + 10.0 * 1.0 * 4e-4)  # kp e + ki e (N T_s)
    outs, state = run([(10.0, 0.0)] + [(100.0, 0.0)] * 10000)
    assert outs[0] == pytest.approx(1.0)  # saturated at the limit
    assert state[0] <= 1.0  # long saturation: the integral stays within the limit
    # error reverses: output leaves saturation at the next run (no wound-up integral)
    _, state = run([(100.0, 0.0)] * 10000, every_n=1)
    outs, _ = run([(0.0, 5.0)], every_n=1, state=state)
    assert outs[0] < 0.6


def test_hall_sectors_follow_backemf_sign_convention():
    assert sorted(pos.HALL_INTERVALS) == [1, 2, 3, 4, 5, 6]
    for code, (sector, start, end) in pos.HALL_INTERVALS.items():
        for th in (start + 0.01, end - 0.01):
            assert pos.hall_code_at(th) == code
            for x in range(3):
                assert bool(code >> x & 1) == (-math.sin(th - x * 2 * math.pi / 3) > 0)
        assert pos.hall_sector(code) == sector
    assert pos.hall_sector(0) == 0 and pos.hall_sector(7) == 0 and math.isnan(pos.hall_angle(7))


def test_encoder_angle():
    assert pos.encoder_angle(2048, 8192, 2) == pytest.approx(math.pi)
    assert pos.encoder_angle(-2048, 8192, 2, 0.1) == pytest.approx(math.pi + 0.1)
