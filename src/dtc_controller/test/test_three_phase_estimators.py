"""Stator flux estimators against analytic signals (000 eqs. 1.22-1.23, 5.36-5.38, Fig. 5.3; 001 eqs. 8-9)."""
import math

import numpy as np
import pytest

from drive_common.samples import DriveSample
from drive_common.signals import clarke
from dtc_controller.core import stator_flux_estimators as sfe
from dtc_controller.core.backemf_table import BackEmfTable
from dtc_controller.core.controller import DtcCore
from dtc_controller.core.line_to_line import DqBackEmf

SHIFT = (0.0, 2 * math.pi / 3, 4 * math.pi / 3)
TS = 1e-4


def trapezoid(theta):
    d = np.degrees(np.mod(theta, 2 * np.pi))
    return np.interp(d, [0, 30, 150, 210, 330, 360], [0, -1, -1, 1, 1, 0])


def flux_source(kind, amplitude=0.1):
    """theta -> true rotor flux (alpha, beta) [Wb] for a sine or ideal-trapezoid machine (zero current)."""
    if kind == 'sine':
        return lambda th: (amplitude * math.cos(th), amplitude * math.sin(th))
    th = np.arange(3600) * 2 * np.pi / 3600
    tab = BackEmfTable.from_phase_constants(*[amplitude * trapezoid(th - s) for s in SHIFT], 1)
    return DqBackEmf(tab).rotor_flux


class Integrator:
    """The modes' voltage-model integrator (:func:`integrator_step`) with its state, from flux psi [Wb]."""

    def __init__(self, kind, r, cutoff=0.0, limit=0.0, psi=(0.0, 0.0), ts=TS):
        self.args = (sfe.INTEGRATORS.index(kind), r, ts, sfe.leak(cutoff, ts), limit)
        self.psi_alpha, self.psi_beta = psi
        self.i_prev = None

    def update(self, v_alpha, v_beta, i_alpha, i_beta):
        """v(k-1) [V], i(k) [A]; the first call only stores i(0)."""
        if self.i_prev is not None:
            self.psi_alpha, self.psi_beta = sfe.integrator_step(
                *self.args, self.psi_alpha, self.psi_beta, *self.i_prev, v_alpha, v_beta, i_alpha, i_beta)
        self.i_prev = (i_alpha, i_beta)


def run(est, psi_fn, omega, t_end, v_offset=(0.0, 0.0), ts=TS):
    """Feed v = d psi/dt (exact increment per sample, as a piecewise-constant voltage) + offset, i = 0."""
    n = int(t_end / ts)
    err = []
    prev = psi_fn(0.0)
    est.update(0.0, 0.0, 0.0, 0.0)
    for k in range(1, n + 1):
        now = psi_fn(omega * k * ts)
        va = (now[0] - prev[0]) / ts + v_offset[0]
        vb = (now[1] - prev[1]) / ts + v_offset[1]
        est.update(va, vb, 0.0, 0.0)
        err.append((est.psi_alpha - now[0], est.psi_beta - now[1], now))
        prev = now
    return err


def test_pure_integrator_exact_and_drifts_with_offset():
    psi = flux_source('sine')
    err = run(Integrator('pure', 0.0, psi=psi(0.0)), psi, 100.0, 0.5)
    assert max(math.hypot(a, b) for a, b, _ in err) < 1e-12
    err = run(Integrator('pure', 0.0, psi=psi(0.0)), psi, 100.0, 2.0, v_offset=(0.05, 0.0))
    assert math.hypot(*err[-1][:2]) == pytest.approx(0.1, rel=0.01)   # 0.05 V * 2 s: linear drift


def test_resistance_term_trapezoidal_current():
    """(1.22): psi(k) = psi(k-1) + (v(k-1) - R (i(k-1) + i(k))/2) T_s."""
    est = Integrator('hu_wu', 2.0, 20.0, limit=10.0, ts=1e-3)
    est.update(0.0, 0.0, 1.0, -1.0)
    est.update(5.0, 5.0, 3.0, -3.0)
    assert (est.psi_alpha, est.psi_beta) == pytest.approx(((5.0 - 2.0 * 2.0) * 1e-3, (5.0 + 2.0 * 2.0) * 1e-3))


@pytest.mark.parametrize('omega', [30.0, 100.0, -60.0])
def test_low_pass_integrator_known_error_and_compensation(omega):
    wc = 5.0
    psi = flux_source('sine')
    est = Integrator('low_pass', 0.0, wc, psi=psi(0.0))
    err = run(est, psi, omega, 3.0)
    _, _, true = err[-1]
    ya, yb = err[-1][0] + true[0], err[-1][1] + true[1]
    gain = math.hypot(ya, yb) / 0.1
    lead = math.remainder(math.atan2(yb, ya) - math.atan2(true[1], true[0]), 2 * math.pi)
    assert gain == pytest.approx(abs(omega) / math.hypot(omega, wc), rel=2e-3)
    assert lead == pytest.approx(math.atan(wc / omega), abs=2e-3)
    ca, cb = sfe.compensate_low_pass(ya, yb, omega, wc)
    assert math.hypot(ca - true[0], cb - true[1]) < 2e-3 * 0.1
    # and the uncompensated error is not small
    assert math.hypot(ya - true[0], yb - true[1]) > 0.02 * 0.1


@pytest.mark.parametrize('kind', ['sine', 'trapezoid'])
def test_hu_wu_converges_from_wrong_start(kind):
    """Fig. 5.3 with the limit at the rotor-flux amplitude: a wrong initial flux decays to the true flux."""
    psi = flux_source(kind)
    limit = 0.1 if kind == 'sine' else DqBackEmfMax(psi)
    est = Integrator('hu_wu', 0.0, 20.0, limit)   # start with no flux at all
    err = run(est, psi, 2 * math.pi * 10, 1.5)
    first = math.hypot(*err[10][:2])
    last = max(math.hypot(a, b) for a, b, _ in err[-1000:])
    assert first > 0.05
    tol = 1e-3 if kind == 'sine' else 0.01      # trapezoid: |psi_r| varies by 1 % around the locus
    assert last < tol * 0.1


def DqBackEmfMax(psi_fn):
    return max(math.hypot(*psi_fn(t)) for t in np.linspace(0, 2 * np.pi, 3601))


@pytest.mark.parametrize('kind', ['sine', 'trapezoid'])
def test_hu_wu_no_drift_with_offset(kind):
    """A DC offset in the measured voltage: the pure integrator drifts away, the Hu-Wu output stays bounded."""
    psi = flux_source(kind)
    limit = 0.1 if kind == 'sine' else DqBackEmfMax(psi)
    hw = Integrator('hu_wu', 0.0, 20.0, limit, psi=psi(0.0))
    pure = Integrator('pure', 0.0, psi=psi(0.0))
    e_hw = run(hw, psi, 2 * math.pi * 10, 3.0, v_offset=(0.1, -0.05))
    e_pure = run(pure, psi, 2 * math.pi * 10, 3.0, v_offset=(0.1, -0.05))
    worst_hw_late = max(math.hypot(a, b) for a, b, _ in e_hw[-3000:])
    worst_hw_mid = max(math.hypot(a, b) for a, b, _ in e_hw[12000:15000])
    assert math.hypot(*e_pure[-1][:2]) > 0.3                 # 0.11 V * 3 s
    # bounded: the leak beyond the limiter circle balances the offset when w_c |d| / 4 = |offset|
    assert worst_hw_late < 1.3 * 4 * math.hypot(0.1, -0.05) / 20.0
    assert worst_hw_late < worst_hw_mid * 1.05                # not growing


@pytest.mark.parametrize('kind', ['sine', 'trapezoid'])
def test_current_model_equals_true_flux(kind):
    """001 eqs. (8)-(9): psi = L i + psi_r(theta) for known currents (table integral for the trapezoid)."""
    L = 3.19e-3
    psi = flux_source(kind, 0.0928)
    table = None
    if kind == 'trapezoid':
        th = np.arange(3600) * 2 * np.pi / 3600
        table = BackEmfTable.from_phase_constants(*[0.0928 * trapezoid(th - s) for s in SHIFT], 1)
    core = DtcCore({'mode': 'three_phase_pmsm', 'three_phase.flux_model': 'current', 'motor.pole_pairs': 1,
                    'motor.inductance': L, 'three_phase.pm_flux': 0.0928}, table)
    rng = np.random.default_rng(4)
    for k, (th, ia, ib) in enumerate(zip(rng.uniform(0, 6.3, 50), rng.uniform(-3, 3, 50), rng.uniform(-3, 3, 50))):
        st = core.update(DriveSample(k, 0.0, (ia, ib, -ia - ib), 70.0, 35.0, 0, th, 0, 0.0))[1]
        ra, rb = psi(th)
        i_al, i_be = clarke(ia, ib, -ia - ib)
        assert (st.flux_alpha, st.flux_beta) == pytest.approx((L * i_al + ra, L * i_be + rb), abs=1e-12)


def test_rotor_angle_5_38_recovers_angle():
    L = 1.0875e-3
    rng = np.random.default_rng(5)
    for kind, tol_deg in (('sine', 1e-9), ('trapezoid', 0.7)):
        psi = flux_source(kind, 0.07)
        for th in rng.uniform(0, 2 * np.pi, 200):
            ia, ib = rng.uniform(-5, 5, 2)
            ra, rb = psi(th)
            est = sfe.rotor_angle(ra + L * ia, rb + L * ib, ia, ib, L)
            assert abs(math.degrees(math.remainder(est - th, 2 * math.pi))) < tol_deg
