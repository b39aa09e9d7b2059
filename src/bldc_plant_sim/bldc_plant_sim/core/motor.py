"""Y-connected three-phase PM motor: electrical constants and mechanics (000 eq. (2.1)-(2.3)).

v_xn = R i_x + (L - M) di_x/dt + e_x, e_x = omega_e k_x(theta_e), T_e = p sum_x k_x i_x,
J dw_m/dt = T_e - T_L - B w_m; isolated star point; psi_x = (L - M) i_x + psi_rx(theta_e).
"""
from __future__ import annotations

from dataclasses import dataclass

from .backemf import BackEmfShape


@dataclass
class Motor:
    """Motor constants (SI) and its back-EMF shape."""

    pole_pairs: int
    resistance: float          # ohm, R_s
    self_inductance: float     # H, L_s
    mutual_inductance: float   # H, M
    inertia: float             # kg m^2, J
    friction: float            # N m s/rad, B
    backemf: BackEmfShape

    @classmethod
    def from_params(cls, p: dict) -> 'Motor':
        return cls(int(p['motor.pole_pairs']), p['motor.resistance'], p['motor.self_inductance'],
                   p['motor.mutual_inductance'], p['motor.inertia'], p['motor.friction'],
                   BackEmfShape.from_params(p))

    @property
    def inductance(self) -> float:
        """Circuit inductance per phase L - M [H]."""
        return self.self_inductance - self.mutual_inductance

    @property
    def time_constant(self) -> float:
        """(L - M) / R [s]."""
        return self.inductance / self.resistance

    def torque(self, theta_e: float, i: tuple) -> float:
        """Electromagnetic torque p sum k_x i_x [N m]."""
        ka, kb, kc = self.backemf.lookup(theta_e)
        return self.pole_pairs * (ka * i[0] + kb * i[1] + kc * i[2])
