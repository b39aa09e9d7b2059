"""Line-to-line transforms and torque of 000 ch. V (eqs. 5.10, 5.13, 5.15, 5.32, 5.33).

Inputs are the ba-ca pair x_ba = x_b - x_a, x_ca = x_c - x_a (measurable without the neutral).
The Park (5.15) has its q row sign-changed: the seed's q lags d, the project's leads. Formulas:
docs/models.md "Line-to-line transforms".
"""
from __future__ import annotations

import math

from drive_common.backemf_file import periodic_list
from drive_common.signals import INV_SQRT3

from .backemf_table import BackEmfTable

_PI6 = math.pi / 6.0
_TWO_THIRDS = 2.0 / 3.0


def line_to_line_clarke(x_ba: float, x_ca: float) -> tuple[float, float]:
    """Eq. (5.10): (alpha, beta) of a zero-sequence-free set from (x_ba, x_ca) (x_a = -(x_ba + x_ca)/3)."""
    return -(x_ba + x_ca) / 3.0, (x_ba - x_ca) * INV_SQRT3


def line_to_line_inverse(x_ba: float, x_ca: float) -> tuple[float, float, float]:
    """Eq. (5.13): (x_a, x_b, x_c) of a zero-sequence-free set from (x_ba, x_ca)."""
    x_a = -(x_ba + x_ca) / 3.0
    return x_a, x_a + x_ba, x_a + x_ca


def line_to_line_park(x_ba: float, x_ca: float, theta: float) -> tuple[float, float]:
    """Eq. (5.15) in the project's Park convention (q leads d): (x_d, x_q) at angle theta [rad]."""
    s_m, s_p = math.sin(theta - _PI6), math.sin(theta + _PI6)
    c_m, c_p = math.cos(theta - _PI6), math.cos(theta + _PI6)
    return (_TWO_THIRDS * (s_m * x_ba - s_p * x_ca), _TWO_THIRDS * (c_m * x_ba - c_p * x_ca))


def line_to_line_park_seed(x_ba: float, x_ca: float, theta: float) -> tuple[float, float]:
    """Eq. (5.15) exactly as printed (seed's q lags d): (x_d, x_q_seed) with x_q_seed = -x_q."""
    d, q = line_to_line_park(x_ba, x_ca, theta)
    return d, -q


def torque_dq(pole_pairs: int, k_d: float, k_q: float, i_d: float, i_q: float) -> float:
    """Eq. (5.32): T [N m] = 3/2 p (k_d i_d + k_q i_q), k in V s/rad, i in A."""
    return 1.5 * pole_pairs * (k_d * i_d + k_q * i_q)


def torque_line_to_line(pole_pairs: int, k_ba: float, k_ca: float, i_ba: float, i_ca: float) -> float:
    """Eq. (5.33)/(B.8): T [N m] = p/3 [(2 k_ba - k_ca) i_ba + (2 k_ca - k_ba) i_ca] (P/6 with P poles)."""
    return pole_pairs / 3.0 * ((2.0 * k_ba - k_ca) * i_ba + (2.0 * k_ca - k_ba) * i_ca)


class DqBackEmf:
    """k_d(theta), k_q(theta) [V s/rad] of a back-EMF table (000 Fig. 5.10: eq. 5.15 applied to
    k_ba, k_ca), its rotor flux [Wb] and the extremes of |psi_r|."""

    __slots__ = ('table', '_kd', '_kq', 'rotor_flux_max', 'rotor_flux_min')

    def __init__(self, table: BackEmfTable) -> None:
        self.table = table
        self._kd = periodic_list(table.columns['k_d'])
        self._kq = periodic_list(table.columns['k_q'])
        mags = [math.hypot(a, b) for a, b in zip(table.rotor_flux_alpha, table.rotor_flux_beta)]
        self.rotor_flux_max = max(mags)
        self.rotor_flux_min = min(mags)

    def k_dq(self, theta: float) -> tuple[float, float]:
        """(k_d, k_q) [V s/rad] at electrical angle theta [rad]."""
        return self.table._at(theta, self._kd, self._kq)

    def rotor_flux(self, theta: float) -> tuple[float, float]:
        """(psi_r_alpha, psi_r_beta) [Wb] at theta [rad] (table integral, zero mean)."""
        return self.table.rotor_flux(theta)


def trapezoid_rotor_flux(k_ll: float) -> dict:
    """|psi_r| [Wb] of an ideal 120-deg flat-top trapezoid with line-to-line peak k_LL [V s/rad]:
    ``at_phase_axis`` (the maximum, the DTIFC start-up flux), ``minimum`` (30 deg off an axis) and
    ``seed_e9`` (000 eq. E.9/5.37: the peak-to-peak swing, twice the minimum)."""
    return {'at_phase_axis': 7.0 * math.pi * k_ll / 36.0,
            'minimum': math.pi * k_ll * INV_SQRT3 / 3.0,
            'seed_e9': 2.0 * math.pi * k_ll * INV_SQRT3 / 3.0}
