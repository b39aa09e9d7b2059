"""Electromagnetic torque from the back-EMF constant table (000 eqs. 2.16 / 4.1, 4.4).

Eq. (2.16)/(4.1) with P poles, T = 3/2 * P/2 * (k_alpha i_alpha + k_beta i_beta);
in pole pairs p (docs/architecture.md): T = 3/2 p (k_alpha i_alpha + k_beta i_beta) [N m].
Phase torques of eq. (4.4): T_ex = e_x i_x / omega_m = p k_x(theta) i_x [N m].
No speed in the denominator, so the estimate holds at standstill.
"""
from __future__ import annotations

from .backemf_table import BackEmfTable


class TorqueEstimator:
    """Torque [N m] from the table k(theta_e) [V s/rad], currents [A], pole pairs p."""

    __slots__ = ('table', 'pole_pairs', '_c')

    def __init__(self, table: BackEmfTable, pole_pairs: int) -> None:
        self.table = table
        self.pole_pairs = int(pole_pairs)
        self._c = 1.5 * self.pole_pairs

    def torque(self, theta: float, i_alpha: float, i_beta: float) -> float:
        """Eq. (2.16)/(4.1): total electromagnetic torque [N m] at electrical angle theta [rad]."""
        k_al, k_be = self.table.k_alpha_beta(theta)
        return self._c * (k_al * i_alpha + k_be * i_beta)

    def phase_torques(self, theta: float, i_a: float, i_b: float, i_c: float) -> tuple[float, float, float]:
        """Eq. (4.4): (T_ea, T_eb, T_ec) [N m]."""
        k_a, k_b, k_c = self.table.k_abc(theta)
        p = self.pole_pairs
        return p * k_a * i_a, p * k_b * i_b, p * k_c * i_c
