"""Back-EMF shapes k_x(theta_e) = d psi_rx / d theta_e [V*s/rad] and their lookup tables.

Phase a's PM flux is maximal at theta_e = 0 (k_a fundamental: -sin(theta_e)); b and c lag by
2 pi/3 and 4 pi/3, scaled by their imbalance gain (001 Table VII); e_x = omega_e * k_x. Shapes:
``trapezoid`` (000 ch. II), ``harmonic``, ``sine`` (001), ``table`` (line-to-line columns,
000 eq. (5.13)); docs/models.md "Back-EMF shapes".
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drive_common import backemf_file, file_cache
from drive_common.file_cache import frozen
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
    """Sine-series amplitudes of the unit trapezoid per unit of n = 1: b_n = 4 sin(n pi/6) /
    (pi n^2 pi/6) for odd n (ramp width pi/6), zero for even n."""
    def b(n: int) -> float:
        if n % 2 == 0:
            return 0.0
        w = math.pi / 6.0
        return 4.0 * math.sin(n * w) / (math.pi * n * n * w)
    return [b(int(n)) / b(1) for n in orders]


@dataclass
class BackEmfShape:
    """Per-phase back-EMF constants of a motor (exact evaluation and lookup tables): kind of
    SHAPES, K [V*s/rad] (flat top or fundamental peak), harmonic series per unit of K, table
    file, (g_a, g_b, g_c) imbalance, table points per cycle."""

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
        key = (self.kind, float(self.constant), tuple(self.orders), tuple(self.coefficients),
               tuple(self.phase_gain), int(self.points))
        # Built once per process and shape (and table file version): shared, read-only.
        if self.kind == 'table':
            tables = file_cache.from_file('backemf_shape', self.table_file, self._build_luts, *key)
        else:
            tables = file_cache.memo(('backemf_shape', *key), self._build_luts)
        self.__dict__.update(tables)

    @classmethod
    def from_params(cls, p: dict) -> 'BackEmfShape':
        return cls(p['motor.backemf.shape'], p['motor.backemf.constant'],
                   tuple(p['motor.backemf.harmonic_orders']),
                   tuple(p['motor.backemf.harmonic_coefficients']),
                   p['motor.backemf.table_file'], tuple(p['motor.backemf.phase_gain']),
                   int(p['motor.backemf.lut_points']))

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

    def _build_luts(self) -> dict:
        """The table columns (shape 'table') and the lookup tables, by attribute name."""
        self._table = None
        if self.kind == 'table':
            cols = backemf_file.read(self.table_file).columns
            self._table = (cols['theta_e'], cols['k_ba'], cols['k_ca'])
        n = self.points
        theta = np.arange(n) * (TWO_PI / n)
        k = self.k_abc(theta)
        psi = backemf_file.periodic_integral(k)      # PM flux linkage
        # Hall: H_x = 1 while the fundamental of k_x is positive.
        c1 = (k * np.exp(-1j * theta)).sum(axis=1) * (2.0 / n)
        fund = np.real(c1[:, None] * np.exp(1j * theta)[None, :])
        bits = (fund > 0.0).astype(int)
        hall = bits[0] | (bits[1] << 1) | (bits[2] << 2)
        # with a wrap-around copy; tuples for the scalar lookup, arrays for the kernels
        lut_k = tuple(tuple(backemf_file.periodic_list(row)) for row in k)
        lut_psi = tuple(tuple(backemf_file.periodic_list(row)) for row in psi)
        return {
            '_table': self._table, 'grid': frozen(theta), 'k_grid': frozen(k), 'psi_grid': frozen(psi),
            'fundamental': frozen(np.abs(c1)), 'lut_k': lut_k,
            'lut_k_array': frozen(np.array(lut_k, dtype=np.float64)),
            'lut_psi_array': frozen(np.array(lut_psi, dtype=np.float64)),
            'lut_hall': tuple(int(h) for h in hall) + (int(hall[0]),),
            'lut_scale': n / TWO_PI}

    def lookup(self, theta: float) -> tuple[float, float, float]:
        """(k_a, k_b, k_c) at theta [rad], linearly interpolated in the table (as plant_kernel.table_at)."""
        x = (theta * self.lut_scale) % self.points
        i = int(x)
        f = x - i
        a, b, c = self.lut_k
        return (a[i] + f * (a[i + 1] - a[i]), b[i] + f * (b[i + 1] - b[i]), c[i] + f * (c[i + 1] - c[i]))

    def hall_code(self, theta: float) -> int:
        """Hall code H_a | H_b << 1 | H_c << 2 at theta [rad]."""
        return self.lut_hall[int((theta * self.lut_scale) % self.points)]

    def line_to_line_peak(self) -> float:
        """max |k_b - k_a| over the cycle [V*s/rad]."""
        return float(np.max(np.abs(self.k_grid[1] - self.k_grid[0])))


def rotor_flux_alpha_beta(shape: BackEmfShape) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(theta, psi_r_alpha, psi_r_beta) over one cycle: zero-mean integrals of k_alpha, k_beta."""
    return (shape.grid, *backemf_file.periodic_integral(np.vstack(clarke(*shape.k_grid))))
