import math

import pytest

from dtc_controller.core.flux_estimator import InverterVoltageModel, VoltageModelFluxEstimator, rotor_flux
from dtc_controller.core.speed_loop import SpeedPI
from dtc_controller.core.torque_estimator import TorqueEstimator
from dtc_controller.core import position as pos
from drive_common.signals import clarke


def test_torque_eq_2_16_equals_phase_sum(trap_table):
    est = TorqueEstimator(trap_table, 2)
    for th in (0.1, 1.0, 2.5, 4.0, 5.9):
        i = (3.0, -1.0, -2.0)
        ia, ib = clarke(*i)
        total = est.torque(th, ia, ib)
        assert total == pytest.approx(sum(est.phase_torques(th, *i)), rel=1e-9)
    # two-phase flat-top: T = p (k_b - k_c) I = 2 * 2K * I in sector 1 (b+, c-)
    k = trap_table.k_abc(0.0)
    assert est.torque(0.0, *clarke(0.0, 5.0, -5.0)) == pytest.approx(2 * (k[1] - k[2]) * 5.0)


def test_flux_integrator_eq_1_22_trapezoidal_current():
    f = VoltageModelFluxEstimator(resistance=0.5, sample_period=1e-4, psi_alpha=0.1)
    f.update(0.0, 0.0, 1.0, 0.0)  # primes i(0)
    f.update(10.0, -2.0, 3.0, 1.0)
    assert f.psi_alpha == pytest.approx(0.1 + (10.0 - 0.5 * 2.0) * 1e-4)
    assert f.psi_beta == pytest.approx((-2.0 - 0.5 * 0.5) * 1e-4)
    assert f.magnitude == pytest.approx(math.hypot(f.psi_alpha, f.psi_beta))
    assert rotor_flux(0.1, 0.2, 1.0, -1.0, 1e-3) == pytest.approx((0.099, 0.201))


def test_voltage_model_diode_clamp():
    ideal = InverterVoltageModel(None, 'ideal')
    diode = InverterVoltageModel(None, 'diode_clamped', 0.05)
    sw = (True, False, False, False, False, True)  # V1: a+, c-, b open
    i = (5.0, 2.0, -7.0)  # b still carries 2 A into the motor: its lower diode clamps it to 0 V
    v_ideal = ideal.voltage(sw, 100.0, 50.0, i)
    assert v_ideal == pytest.approx((50.0, 50.0 / math.sqrt(3)))
    v_diode = diode.voltage(sw, 100.0, 50.0, i)
    # terminals a = 100, b = c = 0 -> three-phase vector (2/3 * 100 - ..., ...)
    assert v_diode == pytest.approx(clarke(100 - 100 / 3, -100 / 3, -100 / 3))
    assert diode.voltage(sw, 100.0, 50.0, (5.0, 0.0, -5.0)) == pytest.approx(v_ideal)
    # open-phase back-EMF bends the vector along the b axis (curved flux locus)
    va, vb = ideal.voltage(sw, 100.0, 50.0, i, emf=(0.0, 10.0, 0.0))
    assert (va - v_ideal[0], vb - v_ideal[1]) == pytest.approx((-5.0, 10.0 * math.sqrt(3) / 2))


def test_speed_pi_runs_every_n_and_antiwindup():
    pi = SpeedPI(kp=0.1, ki=10.0, every_n=4, sample_period=1e-4, torque_limit=1.0)
    outs = [pi.update(1.0, 0.0) for _ in range(8)]
    assert outs[0] == outs[1] == outs[2] == outs[3] and outs[4] != outs[3]
    assert outs[0] == pytest.approx(0.1 + 10.0 * 1.0 * 4e-4)  # kp e + ki e (N T_s)
    assert pi.update(10.0, 0.0) == pytest.approx(1.0)  # saturated at the limit
    for _ in range(10000):
        pi.update(100.0, 0.0)  # long saturation
    assert pi.integral <= 1.0
    # error reverses: output leaves saturation at the next run (no wound-up integral)
    pi2 = SpeedPI(0.1, 10.0, 1, 1e-4, 1.0)
    for _ in range(10000):
        pi2.update(100.0, 0.0)
    out = pi2.update(0.0, 5.0)
    assert out < 0.6
    pi2.set_gains(0.0, 0.0, 1, 1.0)
    assert pi2.update(0.0, 0.0) == pytest.approx(pi2.integral)


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
