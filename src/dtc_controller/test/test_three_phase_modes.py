"""Three-phase modes (three_phase_dtifc / _pmsm / _four_switch) through DtcCore, against a small test motor.

The test motor is an alpha/beta model of a Y-connected surface PM machine at
constant speed (no zero sequence): L di/dt = v - R i - omega_e k_alphabeta(theta),
v from the switch state by the circuit, true flux L i + psi_r(theta). It is
written here (the controller package never imports plant code).
"""
import math
import time

import numpy as np
import pytest

from drive_common.samples import DriveSample
from dtc_controller.core.backemf_table import BackEmfTable
from dtc_controller.core.controller import DtcCore
from dtc_controller.core.vectors import leg_states, phase_voltages
from dtc_controller.core.voltage_drop_compensation import SCHEMES
from drive_common.signals import clarke, inverse_clarke

SHIFT = (0.0, 2 * math.pi / 3, 4 * math.pi / 3)


def trapezoid(theta):
    d = np.degrees(np.mod(theta, 2 * np.pi))
    return np.interp(d, [0, 30, 150, 210, 330, 360], [0, -1, -1, 1, 1, 0])


def make_table(shape, k, p, points=252):
    th = np.arange(points) * 2 * np.pi / points
    return BackEmfTable.from_phase_constants(*[k * shape(th - s) for s in SHIFT], p)


class SimMotor:
    """Constant-speed alpha/beta PM motor with a tabulated back-EMF; Euler with sub-steps."""

    def __init__(self, table, p, R, L, omega_m, v_dc, ts, midpoint=None, theta0=0.0, sub=10):
        self.t, self.p, self.R, self.L = table, p, R, L
        self.w_e = p * omega_m
        self.omega_m = omega_m
        self.v_dc, self.ts, self.mid, self.sub = v_dc, ts, midpoint, sub
        self.theta = theta0
        self.i = [0.0, 0.0]
        self.k = 0

    def sample(self):
        ia, ib, ic = inverse_clarke(*self.i)
        return DriveSample(self.k, self.k * self.ts, (ia, ib, ic), self.v_dc, 0.5 * self.v_dc, 0,
                           self.theta % (2 * math.pi), 0, self.omega_m)

    def torque(self):
        ka, kb = self.t.k_alpha_beta(self.theta)
        return 1.5 * self.p * (ka * self.i[0] + kb * self.i[1])

    def flux(self):
        ra, rb = self.t.rotor_flux(self.theta)
        return self.L * self.i[0] + ra, self.L * self.i[1] + rb

    def advance(self, switch_on):
        va, vb = clarke(*phase_voltages(leg_states(switch_on, self.mid), self.v_dc, 0.5 * self.v_dc))
        h = self.ts / self.sub
        for _ in range(self.sub):
            ka, kb = self.t.k_alpha_beta(self.theta)
            self.i[0] += h / self.L * (va - self.R * self.i[0] - self.w_e * ka)
            self.i[1] += h / self.L * (vb - self.R * self.i[1] - self.w_e * kb)
            self.theta += self.w_e * h
        self.k += 1


def run(core, motor, n):
    log = []
    for _ in range(n):
        s = motor.sample()
        gate, st = core.update(s)
        log.append((st, motor.torque(), motor.flux(), motor.theta % (2 * math.pi), motor.i[:]))
        motor.advance(gate.switch_on)
    return log


# The 000 motor (Appendix A): p = 2, R = 0.315, L - M = 1.0875 mH, k_LL = 0.1146 V s/rad (trapezoid).
P000 = dict(motor_pole_pairs=2)


def dtifc_core(table, **extra):
    params = {'mode': 'three_phase_dtifc', 'sample_period': 15e-6, 'torque_reference': 0.51,
              'torque_band': 0.001, 'dtifc.d_current_band': 0.001, 'motor.pole_pairs': 2,
              'motor.resistance': 0.315, 'motor.inductance': 1.0875e-3}
    params.update(extra)
    return DtcCore(params, table)


@pytest.mark.parametrize('position', ['sensorless', 'encoder'])
def test_dtifc_tracks_torque_and_angle(position):
    table = make_table(trapezoid, 0.0573, 2)
    core = dtifc_core(table, **{'three_phase.position_source': position})
    motor = SimMotor(table, 2, 0.315, 1.0875e-3, 30.0, 40 * math.sqrt(2), 15e-6)
    log = run(core, motor, 8000)
    st0 = log[0][0]
    assert st0.mode == 'three_phase_dtifc' and core.topology == 6
    # start-up: rotor locked at 0, flux = psi_r(0) = 7 pi k_LL / 36 on the alpha axis
    assert st0.flux_alpha == pytest.approx(7 * math.pi * 0.1146 / 36, rel=2e-3)
    assert st0.rotor_angle_estimate == pytest.approx(0.0, abs=1e-6)
    late = log[2000:]
    t_est = np.array([r[0].torque_estimate for r in late])
    t_true = np.array([r[1] for r in late])
    ang_err = np.array([math.remainder(r[0].rotor_angle_estimate - r[3], 2 * math.pi) for r in late])
    i_d = np.array([r[0].d_current for r in late])
    flux_err = np.array([math.hypot(r[0].flux_alpha - r[2][0], r[0].flux_beta - r[2][1]) for r in late])
    assert abs(t_true.mean() - 0.51) < 0.03
    assert np.sqrt(np.mean((t_est - t_true) ** 2)) < 0.02
    assert math.degrees(np.sqrt(np.mean(ang_err ** 2))) < 2.0
    assert abs(i_d.mean()) < 0.3
    assert flux_err.max() < 0.003
    if position == 'sensorless':
        w = np.array([r[0].speed_estimate for r in late[-2000:]])
        assert w.mean() == pytest.approx(60.0, rel=0.05)
    else:
        assert math.isnan(late[-1][0].speed_estimate)
    assert {r[0].d_current_hysteresis for r in late} == {1, -1}
    assert all(r[0].d_current_reference == 0.0 for r in late)
    # Hu-Wu limit = rotor-flux amplitude of the table (7 pi k_LL / 36 for the ideal trapezoid)
    assert core.mode.integrator == 'hu_wu' and core.mode.cutoff == 20.0
    assert core.mode.flux_limit == pytest.approx(7 * math.pi * 0.1146 / 36, rel=2e-3)


def test_dtifc_clockwise():
    table = make_table(trapezoid, 0.0573, 2)
    core = dtifc_core(table, rotation=-1, torque_reference=-0.51)
    motor = SimMotor(table, 2, 0.315, 1.0875e-3, -30.0, 40 * math.sqrt(2), 15e-6)
    late = run(core, motor, 6000)[2000:]
    assert np.mean([r[1] for r in late]) == pytest.approx(-0.51, abs=0.03)
    ang_err = [math.remainder(r[0].rotor_angle_estimate - r[3], 2 * math.pi) for r in late]
    assert math.degrees(np.sqrt(np.mean(np.square(ang_err)))) < 2.0
    assert np.mean([r[0].speed_estimate for r in late[-2000:]]) == pytest.approx(-60.0, rel=0.05)


def test_dtifc_field_weakening_lowers_flux():
    table = make_table(trapezoid, 0.0573, 2)
    core = dtifc_core(table)
    motor = SimMotor(table, 2, 0.315, 1.0875e-3, 30.0, 40 * math.sqrt(2), 15e-6)
    base = run(core, motor, 4000)
    core.reconfigure({'dtifc.d_current_reference': -5.0})
    weak = run(core, motor, 4000)
    m0 = np.mean([math.hypot(*r[2]) for r in base[2000:]])
    m1 = np.mean([math.hypot(*r[2]) for r in weak[2000:]])
    assert np.mean([r[0].d_current for r in weak[2000:]]) == pytest.approx(-5.0, abs=0.5)
    assert m1 < m0 - 0.003                      # |psi_s| = |psi_r + L i| shrinks by ~ L * 5 A


@pytest.mark.parametrize('flux_model', ['voltage', 'current', 'low_pass_compensated'])
@pytest.mark.parametrize('rotation', [1, -1])
def test_pmsm_mode_tracks_torque_and_flux(flux_model, rotation):
    """Classical DTC of a sinusoidal PMSM (000 ch. I / 001): torque and |psi_s| held at the references."""
    table = make_table(lambda t: -np.sin(t), 0.0928, 1)
    core = DtcCore({'mode': 'three_phase_pmsm', 'sample_period': 25e-6, 'motor.pole_pairs': 1,
                    'motor.resistance': 0.466, 'motor.inductance': 3.19e-3, 'rotation': rotation,
                    'torque_reference': 0.3 * rotation, 'torque_band': 0.005, 'flux_band': 0.0005,
                    'flux_control.reference_source': 'constant', 'flux_reference': 0.0928,
                    'three_phase.flux_model': 'current' if flux_model == 'current' else 'voltage',
                    'three_phase.integrator': 'low_pass' if flux_model == 'low_pass_compensated' else 'auto',
                    'three_phase.low_pass_compensation': flux_model == 'low_pass_compensated'}, table)
    motor = SimMotor(table, 1, 0.466, 3.19e-3, rotation * 50.0, 70.0, 25e-6)
    log = run(core, motor, 6000)
    late = log[2000:]
    t_true = np.array([r[1] for r in late])
    mag = np.array([math.hypot(*r[2]) for r in late])
    assert t_true.mean() == pytest.approx(0.3 * rotation, abs=0.03)
    assert mag.mean() == pytest.approx(0.0928, rel=0.02)
    assert {r[0].flux_hysteresis for r in late} == {1, -1}
    flux_err = [math.hypot(r[0].flux_alpha - r[2][0], r[0].flux_beta - r[2][1]) for r in late]
    assert max(flux_err) < 0.002                  # estimate = true flux (LPF error compensated)


def test_four_switch_mode_and_runtime_compensation():
    table = make_table(lambda t: -np.sin(t), 0.0928, 1)
    core = DtcCore({'mode': 'three_phase_four_switch', 'sample_period': 50e-6, 'motor.pole_pairs': 1,
                    'motor.resistance': 0.466, 'motor.inductance': 3.19e-3, 'torque_reference': 0.2,
                    'torque_band': 0.0, 'flux_band': 0.0, 'flux_control.reference_source': 'constant',
                    'flux_reference': 0.0928}, table)
    assert core.topology == 4
    assert core.mode.integrator == 'low_pass' and core.mode.cutoff == 5.0
    motor = SimMotor(table, 1, 0.466, 3.19e-3, 2 * math.pi * 25 / 2, 70.0, 50e-6, midpoint=0)
    log = run(core, motor, 6000)
    late = log[3000:]
    assert all(not r[0].switch_on[0] and not r[0].switch_on[1] for r in log)
    assert {r[0].sector for r in late} == {1, 2, 3, 4}
    assert np.mean([r[1] for r in late]) == pytest.approx(0.2, abs=0.04)
    mode = core.mode
    core.reconfigure({'voltage_drop.compensation': 'proposed', 'voltage_drop.v_ce': 1.0})
    run(core, motor, 1)
    assert core.mode is mode                      # runtime change: estimator state kept
    K = mode.kernel
    assert mode._prm[K.P_SCHEME] == SCHEMES.index('proposed') and mode._prm[K.P_V_CE] == 1.0


def test_per_sample_cost():
    table = make_table(trapezoid, 0.0573, 2)
    for mode in ('three_phase_dtifc', 'three_phase_pmsm', 'three_phase_four_switch'):
        core = DtcCore({'mode': mode, 'motor.pole_pairs': 2}, table)
        s = DriveSample(0, 0.0, (0.5, -0.2, -0.3), 56.6, 28.3, 0, 0.4, 0, 10.0)
        core.update(s)
        n = 5000
        t0 = time.perf_counter()
        for k in range(1, n):
            s.step = k
            core.update(s)
        per = (time.perf_counter() - t0) / n
        assert per < 40e-6, (mode, per)          # target 15 us; ~6-8 us measured on the dev machine
