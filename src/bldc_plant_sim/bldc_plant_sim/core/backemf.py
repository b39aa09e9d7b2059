"""Back-EMF shapes k_x(theta_e) = d psi_rx / d theta_e [V*s/rad] and their lookup tables.

Conventions (docs/architecture.md): the PM flux of phase a is maximal at
theta_e = 0, so the fundamental of k_a is -sin(theta_e); phase b and c are
the same shape shifted by 2 pi/3 and 4 pi/3 (lagging) and scaled by their
imbalance gain (001 Table VII); e_x = omega_e * k_x.

Shapes (per unit of the constant K, phase a before the gain):
- ``trapezoid``: ideal 120 deg flat top -K on theta in [pi/6, 5 pi/6], linear
  30 deg ramps through zero, half-wave antisymmetric (000 ch. II).
- ``harmonic``: -K * sum_n c_n sin(n theta); 000's non-ideal case keeps the
  1st, 3rd and 5th terms of the trapezoid's series, see
  :func:`trapezoid_harmonics` (c_3 = 2/9, c_5 = 1/25 of the fundamental).
- ``sine``: -K sin(theta) (001's PM BLAC, K = psi_PM).
- ``table``: a back-EMF table file (:mod:`drive_common.backemf_file`); the phase
  constants are rebuilt from the line-to-line columns as in 000 eq. (5.13):
  k_a = -(k_ba + k_ca)/3, k_b = k_a + k_ba, k_c = k_a + k_ca (no zero sequence,
  which line-to-line measurements cannot see).

Rotor flux of the ideal trapezoid in the project's Clarke convention (the
DTIFC start-up flux; 000 eq. (5.38) text and Appendix E). With flat top K and
k_LL = 2K the line-to-line peak, k_alpha = k_a - (k_a + k_b + k_c)/3 is
piecewise linear with values (0, -2/3, -1, -4/3, -1, -2/3, 0) K at
theta = 0, 30, ..., 180 deg, so

    psi_r_alpha(0) = -1/2 * integral_0^pi k_alpha dtheta = 7 pi K / 18 = 7 pi k_LL / 36
                   = 0.6109 k_LL,      psi_r_beta(0) = 0.

000 (E.1) is the amplitude-invariant Clarke of the line-to-line set rotated
by +30 deg: alpha' = (x_a - x_b)/sqrt(3) = alpha cos30 - beta sin30 and
beta' = (x_a + x_b - 2 x_c)/3 = alpha sin30 + beta cos30, so both conventions
give the same |psi_r| and differ only in angle. e_alpha' = e_ab/sqrt(3) is a
trapezoid of height k_LL omega_e/sqrt(3) (60 deg flat top, 60 deg ramps), and
its integral over the half period where it is positive is

    (k_LL/sqrt(3)) * (2 pi/3) = 2 pi k_LL / (3 sqrt(3))     (000 eq. (E.9)),

which is the peak-to-peak swing of psi_r_alpha'; the peak of psi_r_alpha'
is half of it, pi k_LL/(3 sqrt(3)) = 0.6046 k_LL (the locus is a near-circle
between 0.6046 and 0.6109 k_LL). E.9 is therefore twice the rotor-flux
amplitude in either convention; test_backemf.py pins all three numbers. For
the 000 motor (k_LL = 0.1146 V*s/rad): psi_r_alpha(0) = 0.0700 Wb.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drive_common import backemf_file
from drive_common.signals import TWO_PI, clarke

SHIFTS = (0.0, TWO_PI / 3.0, 2.0 * TWO_PI / 3.0)
SHAPES = ('trapezoid', 'harmonic', 'sine', 'table')


def trapezoid_unit(theta) -> np.ndarray:
    """Ideal 120 deg flat-top trapezoid, +1 on [pi/6, 5 pi/6], odd, period 2 pi (vectorised)."""
    th = np.mod(np.asarray(theta, dtype=float), TWO_PI)
    half = np.where(th < math.pi, th, th - math.pi)
    sign = np.where(th < math.pi, 1.0, -1.0)
    ramp = math.pi / 6.0
    mag = np.minimum(1.0, np.minimum(half, math.pi - half) / ramp)
    return sign * mag


def trapezoid_harmonics(orders) -> list[float]:
    """Sine-series amplitudes of the unit trapezoid for the given odd orders, per unit of n = 1.

    b_n = 4 sin(n pi/6) / (pi n^2 pi/6) for odd n (ramp width pi/6), zero for even n.
    """
    def b(n: int) -> float:
        if n % 2 == 0:
            return 0.0
        w = math.pi / 6.0
        return 4.0 * math.sin(n * w) / (math.pi * n * n * w)
    return [b(int(n)) / b(1) for n in orders]


@dataclass
class BackEmfShape:
    """Per-phase back-EMF constants of a motor (exact evaluation and fast lookup tables).

    kind: one of SHAPES. constant: K [V*s/rad] (flat top, or fundamental peak).
    orders / coefficients: harmonic series (per unit of K). table_file: CSV for 'table'.
    phase_gain: (g_a, g_b, g_c) imbalance. points: lookup-table resolution.
    """

    kind: str
    constant: float
    orders: tuple = (1.0,)
    coefficients: tuple = (1.0,)
    table_file: str = ''
    phase_gain: tuple = (1.0, 1.0, 1.0)
    points: int = 3072

    def __post_init__(self) -> None:
        if self.kind not in SHAPES:
            raise ValueError(f'back-EMF shape {self.kind!r} is not one of {SHAPES}')
        self._table = None
        if self.kind == 'table':
            cols = backemf_file.read(self.table_file).columns
            self._table = (cols['theta_e'], cols['k_ba'], cols['k_ca'])
        self._build_luts()

    @classmethod
    def from_params(cls, p: dict) -> 'BackEmfShape':
        return cls(p['motor.backemf.shape'], p['motor.backemf.constant'],
                   tuple(p['motor.backemf.harmonic_orders']),
                   tuple(p['motor.backemf.harmonic_coefficients']),
                   p['motor.backemf.table_file'], tuple(p['motor.backemf.phase_gain']),
                   int(p['motor.backemf.lut_points']))

    # ------------------------------------------------------------------ exact shapes
    def _unit_phase_a(self, theta) -> np.ndarray:
        """Phase-a constant before gain, at array theta [rad]."""
        th = np.asarray(theta, dtype=float)
        if self.kind == 'trapezoid':
            return -self.constant * trapezoid_unit(th)
        if self.kind == 'sine':
            return -self.constant * np.sin(th)
        if self.kind == 'harmonic':
            out = np.zeros_like(th)
            for n, c in zip(self.orders, self.coefficients):
                out -= c * np.sin(n * th)
            return self.constant * out
        raise AssertionError('table shapes are per phase')

    def k_abc(self, theta) -> np.ndarray:
        """(3, N) array of k_a, k_b, k_c [V*s/rad] at electrical angles theta (exact shape)."""
        th = np.atleast_1d(np.asarray(theta, dtype=float))
        if self.kind == 'table':
            grid, k_ba, k_ca = self._table
            xp = np.append(grid, grid[0] + TWO_PI)
            wrap = np.mod(th - grid[0], TWO_PI) + grid[0]
            ba = np.interp(wrap, xp, np.append(k_ba, k_ba[0]))
            ca = np.interp(wrap, xp, np.append(k_ca, k_ca[0]))
            ka = -(ba + ca) / 3.0
            phases = (ka, ka + ba, ka + ca)
        else:
            phases = tuple(self._unit_phase_a(th - s) for s in SHIFTS)
        return np.vstack([g * k for g, k in zip(self.phase_gain, phases)])

    # ------------------------------------------------------------------ lookup tables
    def _build_luts(self) -> None:
        n = self.points
        theta = np.arange(n) * (TWO_PI / n)
        k = self.k_abc(theta)
        psi = backemf_file.periodic_integral(k)      # PM flux linkage
        self.grid = theta
        self.k_grid = k
        self.psi_grid = psi
        # Hall: H_x = 1 while the fundamental of k_x is positive.
        c1 = (k * np.exp(-1j * theta)).sum(axis=1) * (2.0 / n)
        fund = np.real(c1[:, None] * np.exp(1j * theta)[None, :])
        bits = (fund > 0.0).astype(int)
        hall = bits[0] | (bits[1] << 1) | (bits[2] << 2)
        self.fundamental = np.abs(c1)
        # Plain Python lists with a wrap-around copy: scalar fast path in the plant.
        self.lut_k = tuple(backemf_file.periodic_list(row) for row in k)
        self.lut_psi = tuple(backemf_file.periodic_list(row) for row in psi)
        self.lut_hall = [int(h) for h in hall] + [int(hall[0])]
        self.lut_scale = n / TWO_PI

    def _interpolate(self, lut, theta: float) -> tuple[float, float, float]:
        """The three phase columns of lut at theta [rad], linearly interpolated (scalar).

        The compiled plant kernels do the same (plant_kernel.emf_at_mid / table_at).
        """
        x = (theta * self.lut_scale) % self.points
        i = int(x)
        f = x - i
        a, b, c = lut
        return (a[i] + f * (a[i + 1] - a[i]), b[i] + f * (b[i + 1] - b[i]), c[i] + f * (c[i + 1] - c[i]))

    def lookup(self, theta: float) -> tuple[float, float, float]:
        """(k_a, k_b, k_c) at theta [rad] by linear interpolation of the table (scalar)."""
        return self._interpolate(self.lut_k, theta)

    def pm_flux(self, theta: float) -> tuple[float, float, float]:
        """PM flux linkages (psi_ra, psi_rb, psi_rc) [Wb] at theta [rad]."""
        return self._interpolate(self.lut_psi, theta)

    def hall_code(self, theta: float) -> int:
        """Hall code H_a | H_b << 1 | H_c << 2 at theta [rad]."""
        return self.lut_hall[int((theta * self.lut_scale) % self.points)]

    def line_to_line_peak(self) -> float:
        """max |k_b - k_a| over the cycle [V*s/rad]."""
        return float(np.max(np.abs(self.k_grid[1] - self.k_grid[0])))


def rotor_flux_alpha_beta(shape: BackEmfShape) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(theta, psi_r_alpha, psi_r_beta) over one cycle: zero-mean integrals of k_alpha, k_beta."""
    return (shape.grid, *backemf_file.periodic_integral(np.vstack(clarke(*shape.k_grid))))
