"""Stator flux estimators of the DTC modes (000 eqs. 1.22-1.24, 5.36-5.38; 001 eqs. 8-9, 15-16).

The voltage models integrate v(k-1) - R_s (i(k-1) + i(k))/2 (:func:`trapezoid_flux_step`);
:func:`integrator_step` adds the leak (1 - exp(-w_c T_s)) of the low-pass integrator (001, undone
by :func:`compensate_low_pass`) or of the Hu-Wu integrator (000 Fig. 5.3, amplitude limiter).
Equations: docs/models.md "Stator flux estimators".
"""
from __future__ import annotations

import math

from drive_common.compiled import njit
from drive_common.signals import TWO_PI


@njit
def trapezoid_flux_step(psi_alpha: float, psi_beta: float, v_alpha_prev: float, v_beta_prev: float,
                        r: float, ts: float, i_prev_alpha: float, i_prev_beta: float,
                        i_alpha: float, i_beta: float):
    """Eqs. (1.22)-(1.23): the stator flux [Wb] one sample T_s [s] on, with v(k-1) [V] and the
    mean of i(k-1), i(k) [A] through R [ohm]."""
    return (psi_alpha + (v_alpha_prev - r * 0.5 * (i_prev_alpha + i_alpha)) * ts,
            psi_beta + (v_beta_prev - r * 0.5 * (i_prev_beta + i_beta)) * ts)


def leak(cutoff: float, sample_period: float) -> float:
    """1 - exp(-w_c T_s): the per-sample leak of an integrator with cutoff w_c [rad/s]."""
    return 1.0 - math.exp(-float(cutoff) * float(sample_period))


INTEGRATORS = ('pure', 'low_pass', 'hu_wu')
"""Integrator kinds; :func:`integrator_step` takes the position in this tuple."""


@njit
def integrator_step(kind: int, r: float, ts: float, leak: float, limit: float, pa: float, pb: float,
                    i_prev_alpha: float, i_prev_beta: float, v_alpha_prev: float, v_beta_prev: float,
                    i_alpha: float, i_beta: float):
    """New (psi_alpha, psi_beta) [Wb] of a primed voltage-model integrator (module doc), kind 0 pure,
    1 low-pass, 2 Hu-Wu (leak = 1 - exp(-w_c T_s), limit [Wb])."""
    pa_new, pb_new = trapezoid_flux_step(pa, pb, v_alpha_prev, v_beta_prev, r, ts,
                                         i_prev_alpha, i_prev_beta, i_alpha, i_beta)
    if kind == 1:
        pa_new -= leak * pa
        pb_new -= leak * pb
    elif kind == 2:
        m2 = pa * pa + pb * pb
        if m2 > limit * limit:
            # y - z = y (1 - L/|y|): leak only the part beyond the limiter circle.
            g = leak * (1.0 - limit / math.sqrt(m2))
            pa_new -= g * pa
            pb_new -= g * pb
    return pa_new, pb_new


@njit
def compensate_low_pass(psi_alpha: float, psi_beta: float, omega_e: float, cutoff: float,
                        min_speed: float = 1e-3) -> tuple[float, float]:
    """Undo the LPF's gain/phase error for a sinusoidal flux at w_e [rad/s]: psi = y (1 - j w_c / w_e);
    unchanged below ``min_speed`` (the correction diverges at standstill)."""
    if abs(omega_e) < min_speed:
        return psi_alpha, psi_beta
    r = cutoff / omega_e
    return psi_alpha + r * psi_beta, psi_beta - r * psi_alpha


@njit
def rotor_angle(psi_alpha: float, psi_beta: float, i_alpha: float, i_beta: float, inductance: float) -> float:
    """000 eq. (5.38): electrical rotor angle [rad, 0..2 pi) from stator flux [Wb], current [A], L_s [H]."""
    return math.atan2(psi_beta - inductance * i_beta, psi_alpha - inductance * i_alpha) % TWO_PI

