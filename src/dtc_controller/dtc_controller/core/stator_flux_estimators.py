"""Stator flux estimators for the three-phase modes (000 eqs. 1.22-1.23, 5.36-5.38; 001 eqs. 8-9, 15-16).

The voltage-model estimators integrate the EMF x = v(k-1) - R_s (i(k-1) + i(k))/2
and share the interface of :class:`flux_estimator.VoltageModelFluxEstimator`, the
pure integrator here (:data:`PureIntegrator`): :class:`LowPassIntegrator` (001,
undone by :func:`compensate_low_pass`) and :class:`HuWuIntegrator` (000 Fig. 5.3,
amplitude limiter). :class:`CurrentModelFlux` is 001 eqs. (8)-(9);
:func:`rotor_angle` is 000 eq. (5.38). Discretisation: exact for constant x over a
sample; the leak terms use (1 - exp(-w_c T_s)). Equations: docs/models.md
"Stator flux estimators".
"""
from __future__ import annotations

import math

from drive_common.compiled import interpreted, njit

from .flux_estimator import VoltageModelFluxEstimator, trapezoid_flux_step

PureIntegrator = VoltageModelFluxEstimator
"""000 eqs. (1.22)-(1.23) / 001 eqs. (15)-(16): open-loop integration (helper-2's estimator)."""

TWO_PI = 2.0 * math.pi


class _LeakyBase(VoltageModelFluxEstimator):
    """The pure integrator's state, ``reset``, ``magnitude`` and ``angle`` plus the leak w_c."""

    __slots__ = ('cutoff', '_leak')

    def __init__(self, resistance: float, sample_period: float, cutoff: float,
                 psi_alpha: float = 0.0, psi_beta: float = 0.0) -> None:
        super().__init__(resistance, sample_period, psi_alpha, psi_beta)
        self.set_cutoff(cutoff)

    def set_cutoff(self, cutoff: float) -> None:
        """w_c [rad/s]."""
        self.cutoff = float(cutoff)
        self._leak = 1.0 - math.exp(-self.cutoff * self.sample_period)


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


_integrator_step = interpreted(integrator_step)   # the classes' per-call path (no dispatch cost)


class LowPassIntegrator(_LeakyBase):
    """psi(k) = psi(k-1) + T_s x - (1 - e^{-w_c T_s}) psi(k-1) (001 sec. IV, w_c = 5 rad/s)."""

    __slots__ = ()

    def update(self, v_alpha_prev: float, v_beta_prev: float, i_alpha: float, i_beta: float) -> tuple[float, float]:
        """Advance with v(k-1) [V], i(k) [A]; return (psi_alpha, psi_beta) [Wb]."""
        if self._primed:
            self.psi_alpha, self.psi_beta = _integrator_step(
                1, self.resistance, self.sample_period, self._leak, 0.0, self.psi_alpha, self.psi_beta,
                self._i_alpha, self._i_beta, v_alpha_prev, v_beta_prev, i_alpha, i_beta)
        self._primed = True
        self._i_alpha = i_alpha
        self._i_beta = i_beta
        return self.psi_alpha, self.psi_beta


class HuWuIntegrator(_LeakyBase):
    """Modified integrator with amplitude limiter (000 Fig. 5.3 / Hu-Wu algorithm 2); limit [Wb]."""

    __slots__ = ('limit',)

    def __init__(self, resistance: float, sample_period: float, cutoff: float, limit: float,
                 psi_alpha: float = 0.0, psi_beta: float = 0.0) -> None:
        self.limit = float(limit)
        super().__init__(resistance, sample_period, cutoff, psi_alpha, psi_beta)

    def update(self, v_alpha_prev: float, v_beta_prev: float, i_alpha: float, i_beta: float) -> tuple[float, float]:
        """Advance with v(k-1) [V], i(k) [A]; return (psi_alpha, psi_beta) [Wb]."""
        if self._primed:
            self.psi_alpha, self.psi_beta = _integrator_step(
                2, self.resistance, self.sample_period, self._leak, self.limit, self.psi_alpha,
                self.psi_beta, self._i_alpha, self._i_beta, v_alpha_prev, v_beta_prev, i_alpha, i_beta)
        self._primed = True
        self._i_alpha = i_alpha
        self._i_beta = i_beta
        return self.psi_alpha, self.psi_beta


@njit
def compensate_low_pass(psi_alpha: float, psi_beta: float, omega_e: float, cutoff: float,
                        min_speed: float = 1e-3) -> tuple[float, float]:
    """Undo the LPF's gain/phase error for a sinusoidal flux at w_e [rad/s]: psi = y (1 - j w_c / w_e).

    Returns the input unchanged below ``min_speed`` (the correction diverges at standstill).
    """
    if abs(omega_e) < min_speed:
        return psi_alpha, psi_beta
    r = cutoff / omega_e
    return psi_alpha + r * psi_beta, psi_beta - r * psi_alpha


class CurrentModelFlux:
    """001 eqs. (8)-(9): psi_s = L_s i + psi_r(theta_e) [Wb].

    rotor_flux: a callable theta -> (psi_r_alpha, psi_r_beta) (e.g.
    :meth:`line_to_line.DqBackEmf.rotor_flux`), or None to use psi_m (cos, sin).
    """

    __slots__ = ('inductance', 'psi_m', '_rf', 'psi_alpha', 'psi_beta')

    def __init__(self, inductance: float, psi_m: float = 0.0, rotor_flux=None) -> None:
        self.inductance = float(inductance)
        self.psi_m = float(psi_m)
        self._rf = rotor_flux
        self.psi_alpha = 0.0
        self.psi_beta = 0.0

    def update(self, theta: float, i_alpha: float, i_beta: float) -> tuple[float, float]:
        """Flux [Wb] at rotor angle theta [rad] and currents [A]."""
        if self._rf is None:
            ra, rb = self.psi_m * math.cos(theta), self.psi_m * math.sin(theta)
        else:
            ra, rb = self._rf(theta)
        self.psi_alpha = self.inductance * i_alpha + ra
        self.psi_beta = self.inductance * i_beta + rb
        return self.psi_alpha, self.psi_beta

    @property
    def magnitude(self) -> float:
        return math.hypot(self.psi_alpha, self.psi_beta)


@njit
def rotor_angle(psi_alpha: float, psi_beta: float, i_alpha: float, i_beta: float, inductance: float) -> float:
    """000 eq. (5.38): electrical rotor angle [rad, 0..2 pi) from stator flux [Wb], current [A], L_s [H]."""
    return math.atan2(psi_beta - inductance * i_beta, psi_alpha - inductance * i_alpha) % TWO_PI


def make_voltage_model(kind: str, resistance: float, sample_period: float, cutoff: float, limit: float):
    """Estimator by name: 'pure', 'low_pass' (cutoff) or 'hu_wu' (cutoff, limit)."""
    if kind == 'pure':
        return PureIntegrator(resistance, sample_period)
    if kind == 'low_pass':
        return LowPassIntegrator(resistance, sample_period, cutoff)
    if kind == 'hu_wu':
        return HuWuIntegrator(resistance, sample_period, cutoff, limit)
    raise ValueError(f'unknown integrator {kind!r} (pure, low_pass, hu_wu)')
