"""Back-EMF constant table k(theta_e) [V*s/rad]: the controller's only knowledge of the back-EMF shape.

File format: :mod:`drive_common.backemf_file`; ``e = omega_e * k(theta_e)``, looked up linearly
and wrapped, as the dissertation did with its 252 measured points (000 ch. V). The rotor flux is
the zero-mean integral of k over theta, the flux reference |psi_r(theta_e)| of eq. (2.20) / (4.3).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from drive_common import backemf_file, file_cache
from drive_common.backemf_file import COLUMNS, HEADER, BackEmfTableError, periodic_integral, periodic_list
from drive_common.file_cache import frozen
from drive_common.signals import TWO_PI

__all__ = ['COLUMNS', 'HEADER', 'BackEmfTable', 'BackEmfTableError', 'periodic_list']

@dataclass
class BackEmfTable:
    """Back-EMF constants [V*s/rad] evenly spaced over one electrical period: columns {name in COLUMNS:
    array of ``points`` values}, metadata the file's ``# key: value`` strings."""

    columns: dict
    pole_pairs: int
    metadata: dict = field(default_factory=dict)
    source_path: str = '<memory>'

    def __post_init__(self) -> None:
        n = len(self.columns['theta_e'])
        if n < 6:
            raise BackEmfTableError(f'{self.source_path}: needs at least 6 points, has {n}')
        self.points = n
        self._scale = n / TWO_PI
        # lists with a wrap-around copy of the first point
        self._ka = periodic_list(self.columns['k_a'])
        self._kb = periodic_list(self.columns['k_b'])
        self._kc = periodic_list(self.columns['k_c'])
        self._kal = periodic_list(self.columns['k_alpha'])
        self._kbe = periodic_list(self.columns['k_beta'])
        psi_a, psi_b = periodic_integral(self.columns['k_alpha']), periodic_integral(self.columns['k_beta'])
        self.rotor_flux_alpha, self.rotor_flux_beta = psi_a, psi_b
        self._psia = periodic_list(psi_a)
        self._psib = periodic_list(psi_b)
        self._psim = periodic_list(np.hypot(psi_a, psi_b))

    @classmethod
    def from_phase_constants(cls, k_a, k_b, k_c, pole_pairs: int, source: str = 'synthetic',
                             convention: str = 'docs/architecture.md') -> 'BackEmfTable':
        """Table from per-phase constants sampled at theta_e = 2 pi n / N; derived columns computed."""
        cols = backemf_file.columns_from_phases(k_a, k_b, k_c)
        meta = {'pole_pairs': str(pole_pairs), 'points': str(len(cols['theta_e'])), 'source': source,
                'convention': convention}
        return cls(cols, int(pole_pairs), meta)

    @classmethod
    def load(cls, path, expected_pole_pairs: int | None = None) -> 'BackEmfTable':
        """Read and check a table file: every column, ``pole_pairs`` and ``points`` metadata, even
        angles, consistent derived columns, the motor's pole pairs; BackEmfTableError naming the
        file and line. Cached per file version (:mod:`drive_common.file_cache`): do not change it."""
        return file_cache.from_file('backemf_table', path, lambda: cls._load(path, expected_pole_pairs),
                                    expected_pole_pairs, cls)

    @classmethod
    def _load(cls, path, expected_pole_pairs: int | None) -> 'BackEmfTable':
        table = backemf_file.read(path)
        name, line = table.path, table.header_line
        missing = [c for c in COLUMNS if c not in table.columns]
        if missing:
            raise BackEmfTableError(f'{name}:{line}: header lacks column(s) {",".join(missing)} '
                                    f'(the controller needs "{HEADER}")')
        for key in ('pole_pairs', 'points'):
            if key not in table.metadata:
                raise BackEmfTableError(f'{name}:{line}: metadata "# {key}: ..." missing')
        try:
            pole_pairs = int(table.metadata['pole_pairs'])
        except ValueError as exc:
            raise BackEmfTableError(f'{name}:{line}: metadata pole_pairs must be an integer ({exc})') from exc
        if expected_pole_pairs is not None and pole_pairs != expected_pole_pairs:
            raise BackEmfTableError(f'{name}:{line}: table is for pole_pairs {pole_pairs}, '
                                    f'controller motor.pole_pairs is {expected_pole_pairs}')
        cols = {c: table.columns[c] for c in COLUMNS}
        _check_consistency(name, cols, table.row_lines)
        loaded = cls(cols, pole_pairs, table.metadata, name)
        frozen(loaded.rotor_flux_alpha), frozen(loaded.rotor_flux_beta)
        return loaded

    def write(self, path) -> None:
        """Write in the table file format (used by tests; the plant's generator writes the real one)."""
        meta = dict(self.metadata, pole_pairs=str(self.pole_pairs), points=str(self.points))
        backemf_file.write(path, self.columns, meta)

    def _at(self, theta: float, *cols) -> tuple:
        """Columns (periodic lists) at theta [rad], linear and wrapped."""
        x = theta * self._scale
        i = math.floor(x)
        f = x - i
        i %= self.points
        return tuple(c[i] + f * (c[i + 1] - c[i]) for c in cols)

    def k_alpha_beta(self, theta: float) -> tuple[float, float]:
        """(k_alpha, k_beta) [V*s/rad] at electrical angle theta [rad]."""
        return self._at(theta, self._kal, self._kbe)

    def k_abc(self, theta: float) -> tuple[float, float, float]:
        """(k_a, k_b, k_c) [V*s/rad] at theta [rad]."""
        return self._at(theta, self._ka, self._kb, self._kc)

    def rotor_flux(self, theta: float) -> tuple[float, float]:
        """(psi_r_alpha, psi_r_beta) [Wb]: integral of k over theta, zero mean (eq. 2.19's phi_r)."""
        return self._at(theta, self._psia, self._psib)

    def rotor_flux_magnitude(self, theta: float) -> float:
        """|psi_r(theta)| [Wb]: the position-dependent stator flux reference of eq. (2.20)/(4.3)."""
        return self._at(theta, self._psim)[0]


def _check_consistency(name: str, cols: dict, row_lines: list) -> None:
    """Evenly spaced angles over [0, 2 pi) and derived columns matching the per-phase ones."""
    theta = cols['theta_e']
    n = len(theta)
    expected = np.arange(n) * (TWO_PI / n)
    bad = np.flatnonzero(np.abs(theta - expected) > 1e-6 * TWO_PI / n + 1e-9)
    if bad.size:
        j = int(bad[0])
        raise BackEmfTableError(f'{name}:{row_lines[j]}: theta_e not evenly spaced over [0, 2*pi): '
                                f'{theta[j]!r}, expected {expected[j]!r}')
    scale = max(1e-12, float(np.max(np.abs(np.column_stack([cols['k_a'], cols['k_b'], cols['k_c']])))))
    tol = 1e-4 * scale + 1e-12  # allows ~6 significant digits in the file
    derived = backemf_file.columns_from_phases(cols['k_a'], cols['k_b'], cols['k_c'])
    for col in COLUMNS[4:]:
        err = np.abs(cols[col] - derived[col])
        if np.max(err) > tol:
            j = int(np.argmax(err))
            raise BackEmfTableError(f'{name}:{row_lines[j]}: column {col} does not match the per-phase '
                                    f'columns (got {cols[col][j]!r}, convention gives {derived[col][j]!r})')
