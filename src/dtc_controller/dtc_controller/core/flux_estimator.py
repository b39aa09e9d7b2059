"""Voltage-model stator flux estimator (000 eqs. 1.22-1.24, 2.18-2.19, 2.20).

Eqs. (1.22)-(1.23), trapezoidal current:
``psi(k) = psi(k-1) + (v(k-1) - R (i(k-1) + i(k))/2) T_s`` in alpha/beta [Wb],
with v(k-1) the alpha/beta voltage applied over the previous sample
(reconstructed from the previous switch state and the measured DC link; see
:class:`InverterVoltageModel`). Rotor flux, eq. (2.19):
``psi_r = psi_s - (L - M) i``. Flux reference for the optional flux control,
eq. (2.20): |psi_s|* = |psi_r(theta_e)|, from the back-EMF table's integral.
"""
from __future__ import annotations

import math

from drive_common.compiled import njit

from .vectors import LOW, HIGH, OPEN, VoltageVector, leg_states, voltage_coefficients



@njit
def trapezoid_flux_step(psi_alpha: float, psi_beta: float, v_alpha_prev: float, v_beta_prev: float,
                        r: float, ts: float, i_prev_alpha: float, i_prev_beta: float,
                        i_alpha: float, i_beta: float):
    """Eqs. (1.22)-(1.23): the stator flux [Wb] one sample T_s [s] on, with v(k-1) [V] and the
    mean of i(k-1), i(k) [A] through R [ohm] (trapezoidal). Shared by every voltage model."""
    return (psi_alpha + (v_alpha_prev - r * 0.5 * (i_prev_alpha + i_alpha)) * ts,
            psi_beta + (v_beta_prev - r * 0.5 * (i_prev_beta + i_beta)) * ts)

class VoltageModelFluxEstimator:
    """Open-loop integrator of eqs. (1.22)-(1.23); R [ohm], T_s [s], state in Wb."""

    __slots__ = ('resistance', 'sample_period', 'psi_alpha', 'psi_beta', '_i_alpha', '_i_beta', '_primed')

    def __init__(self, resistance: float, sample_period: float,
                 psi_alpha: float = 0.0, psi_beta: float = 0.0) -> None:
        self.resistance = float(resistance)
        self.sample_period = float(sample_period)
        self.reset(psi_alpha, psi_beta)

    def reset(self, psi_alpha: float = 0.0, psi_beta: float = 0.0) -> None:
        """Set the initial flux (e.g. the rotor flux at the encoder angle, 000 ch. I end)."""
        self.psi_alpha = float(psi_alpha)
        self.psi_beta = float(psi_beta)
        self._primed = False
        self._i_alpha = 0.0
        self._i_beta = 0.0

    def update(self, v_alpha_prev: float, v_beta_prev: float, i_alpha: float, i_beta: float) -> tuple[float, float]:
        """Advance one sample with v(k-1) [V] and i(k) [A]; return (psi_alpha, psi_beta) [Wb].

        The first call only stores i(0) (no voltage applied before it).
        """
        if self._primed:
            self.psi_alpha, self.psi_beta = trapezoid_flux_step(
                self.psi_alpha, self.psi_beta, v_alpha_prev, v_beta_prev, self.resistance,
                self.sample_period, self._i_alpha, self._i_beta, i_alpha, i_beta)
        self._primed = True
        self._i_alpha = i_alpha
        self._i_beta = i_beta
        return self.psi_alpha, self.psi_beta

    @property
    def magnitude(self) -> float:
        """Eq. (1.24): |psi_s| [Wb]."""
        return math.hypot(self.psi_alpha, self.psi_beta)

    @property
    def angle(self) -> float:
        """Eq. (1.24): angle of psi_s [rad], [0, 2 pi)."""
        return math.atan2(self.psi_beta, self.psi_alpha) % (2.0 * math.pi)


def rotor_flux(psi_alpha: float, psi_beta: float, i_alpha: float, i_beta: float,
               inductance: float) -> tuple[float, float]:
    """Eq. (2.19)/(4.2): rotor flux [Wb] from stator flux [Wb], current [A] and L - M [H]."""
    return psi_alpha - inductance * i_alpha, psi_beta - inductance * i_beta


class InverterVoltageModel:
    """alpha/beta voltage [V] applied by a switch state, from the DC-link measurement.

    mode 'ideal': open legs carry no current, the open phase's back-EMF is
    taken as zero unless ``emf`` is given (the seed's straight-sided hexagon);
    'diode_clamped': a leg with both switches off whose phase current is still
    above ``current_threshold`` conducts through a free-wheeling diode, so its
    terminal is at the negative rail (i > 0, motor-ward) or the positive rail
    (i < 0) -- the commutation dips of 000 Figs. 2.1/2.5.
    The per-sample work is a dict lookup of precomputed linear coefficients.
    """

    def __init__(self, midpoint_phase: int | None, mode: str = 'ideal', current_threshold: float = 0.05) -> None:
        if mode not in ('ideal', 'diode_clamped'):
            raise ValueError(f'unknown voltage model {mode!r}')
        self.midpoint_phase = midpoint_phase
        self.diode = mode == 'diode_clamped'
        self.threshold = float(current_threshold)
        self._legs_cache: dict = {}

    def _legs(self, switch_on: tuple) -> tuple:
        legs = self._legs_cache.get(switch_on)
        if legs is None:
            legs = self._legs_cache[switch_on] = leg_states(switch_on, self.midpoint_phase)
        return legs

    def voltage(self, switch_on: tuple, v_dc: float, v_mid: float, currents: tuple,
                emf: tuple | None = None) -> tuple[float, float]:
        """(v_alpha, v_beta) [V] over a sample with this switch state, DC link v_dc, midpoint v_mid [V].

        currents: phase currents [A] at the start of the sample (for diode clamping);
        emf: phase back-EMFs [V] used for open phases, or None for zero.
        """
        legs = self._legs(switch_on)
        if self.diode and OPEN in legs:
            thr = self.threshold
            legs = tuple((LOW if currents[x] > thr else HIGH if currents[x] < -thr else OPEN)
                         if legs[x] == OPEN else legs[x] for x in range(3))
        a_dc, a_mid, b_dc, b_mid, terms = voltage_coefficients(legs)
        v_al = a_dc * v_dc + a_mid * v_mid
        v_be = b_dc * v_dc + b_mid * v_mid
        if emf is not None:
            for x, ka, kb in terms:
                v_al += ka * emf[x]
                v_be += kb * emf[x]
        return v_al, v_be


__all__ = ['VoltageModelFluxEstimator', 'trapezoid_flux_step', 'rotor_flux', 'InverterVoltageModel', 'VoltageVector']
