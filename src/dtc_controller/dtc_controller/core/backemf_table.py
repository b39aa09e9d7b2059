"""Back-EMF constant table k(theta_e): the controller's only knowledge of the back-EMF shape.

File format (docs/architecture.md, written by the plant's back-EMF generator
test): ``#`` comment lines first, among them ``# key: value`` metadata
(``pole_pairs``, ``points``, ``source``, ``convention``); then the header
line ``theta_e,k_a,k_b,k_c,k_ba,k_ca,k_alpha,k_beta,k_d,k_q`` and
``points`` rows evenly spaced over [0, 2 pi). Every k is in V*s/rad (Wb):
``e = omega_e * k(theta_e)``. Lookups interpolate linearly and wrap the
angle, as the dissertation did with its 252 measured points (000 ch. V).

The rotor (PM) flux linkage is recovered by integrating k over theta
(k = d psi_r / d theta_e, zero mean), which gives the position-dependent
flux reference |psi_r(theta_e)| of eq. (2.20) / (4.3).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .transforms import INV_SQRT3, TWO_PI

COLUMNS = ('theta_e', 'k_a', 'k_b', 'k_c', 'k_ba', 'k_ca', 'k_alpha', 'k_beta', 'k_d', 'k_q')
HEADER = ','.join(COLUMNS)
REQUIRED_METADATA = ('pole_pairs', 'points')


class BackEmfTableError(ValueError):
    """A back-EMF table file is malformed or does not match the motor; names file and problem."""


@dataclass
class BackEmfTable:
    """Tabulated back-EMF constants over one electrical period (V*s/rad), evenly spaced.

    columns: name -> numpy array (``points`` values), names as in COLUMNS.
    metadata: the file's ``# key: value`` pairs (strings).
    """

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
        # Python lists with a wrap-around copy of the first point: scalar fast path.
        self._ka = periodic_list(self.columns['k_a'])
        self._kb = periodic_list(self.columns['k_b'])
        self._kc = periodic_list(self.columns['k_c'])
        self._kal = periodic_list(self.columns['k_alpha'])
        self._kbe = periodic_list(self.columns['k_beta'])
        psi_a, psi_b = _integrate_zero_mean(self.columns['k_alpha']), _integrate_zero_mean(self.columns['k_beta'])
        self.rotor_flux_alpha = psi_a
        self.rotor_flux_beta = psi_b
        self._psia = periodic_list(psi_a)
        self._psib = periodic_list(psi_b)
        self._psim = periodic_list(np.hypot(psi_a, psi_b))

    # ----------------------------------------------------------------- construction
    @classmethod
    def from_phase_constants(cls, k_a, k_b, k_c, pole_pairs: int, source: str = 'synthetic',
                             convention: str = 'docs/architecture.md') -> 'BackEmfTable':
        """Table from per-phase constants sampled at theta_e = 2 pi n / N; derived columns computed."""
        k_a, k_b, k_c = (np.asarray(x, dtype=float) for x in (k_a, k_b, k_c))
        n = len(k_a)
        theta = np.arange(n) * (TWO_PI / n)
        k_alpha = (2.0 * k_a - k_b - k_c) / 3.0
        k_beta = (k_b - k_c) * INV_SQRT3
        cos, sin = np.cos(theta), np.sin(theta)
        cols = {'theta_e': theta, 'k_a': k_a, 'k_b': k_b, 'k_c': k_c,
                'k_ba': k_b - k_a, 'k_ca': k_c - k_a, 'k_alpha': k_alpha, 'k_beta': k_beta,
                'k_d': k_alpha * cos + k_beta * sin, 'k_q': -k_alpha * sin + k_beta * cos}
        meta = {'pole_pairs': str(pole_pairs), 'points': str(n), 'source': source,
                'convention': convention}
        return cls(cols, int(pole_pairs), meta)

    @classmethod
    def load(cls, path, expected_pole_pairs: int | None = None) -> 'BackEmfTable':
        """Read and check a table file; raise BackEmfTableError naming the file and the problem.

        expected_pole_pairs: the motor's pole pairs from the controller parameters;
        a file for another motor is rejected.
        """
        name = str(path)
        try:
            text = Path(path).read_text()
        except OSError as exc:
            raise BackEmfTableError(f'{name}: cannot read back-EMF table ({exc.strerror or exc})') from exc
        metadata: dict[str, str] = {}
        lines = text.splitlines()
        idx = 0
        while idx < len(lines) and (lines[idx].startswith('#') or not lines[idx].strip()):
            body = lines[idx][1:].strip()
            if ':' in body:
                key, value = body.split(':', 1)
                metadata[key.strip()] = value.strip()
            idx += 1
        if idx >= len(lines):
            raise BackEmfTableError(f'{name}: no header line (expected "{HEADER}")')
        header = tuple(h.strip() for h in lines[idx].split(','))
        if header != COLUMNS:
            raise BackEmfTableError(f'{name}: line {idx + 1}: header is "{lines[idx].strip()}", expected "{HEADER}"')
        for key in REQUIRED_METADATA:
            if key not in metadata:
                raise BackEmfTableError(f'{name}: metadata "# {key}: ..." missing')
        try:
            pole_pairs = int(metadata['pole_pairs'])
            points = int(metadata['points'])
        except ValueError as exc:
            raise BackEmfTableError(f'{name}: metadata pole_pairs/points must be integers ({exc})') from exc
        rows = []
        for lineno, line in enumerate(lines[idx + 1:], start=idx + 2):
            if not line.strip() or line.startswith('#'):
                continue
            parts = line.split(',')
            if len(parts) != len(COLUMNS):
                raise BackEmfTableError(f'{name}: line {lineno}: {len(parts)} values, expected {len(COLUMNS)}')
            try:
                values = [float(p) for p in parts]
            except ValueError as exc:
                raise BackEmfTableError(f'{name}: line {lineno}: not a number ({exc})') from exc
            if not all(math.isfinite(v) for v in values):
                raise BackEmfTableError(f'{name}: line {lineno}: non-finite value')
            rows.append(values)
        if len(rows) != points:
            raise BackEmfTableError(f'{name}: metadata says points: {points} but the file has {len(rows)} rows')
        if expected_pole_pairs is not None and pole_pairs != expected_pole_pairs:
            raise BackEmfTableError(f'{name}: table is for pole_pairs {pole_pairs}, '
                                    f'controller motor.pole_pairs is {expected_pole_pairs}')
        data = np.array(rows, dtype=float)
        cols = {c: data[:, j].copy() for j, c in enumerate(COLUMNS)}
        _check_consistency(name, cols)
        return cls(cols, pole_pairs, metadata, name)

    def write(self, path) -> None:
        """Write in the file format above (used by tests; the plant's generator writes the real one)."""
        meta = dict(self.metadata)
        meta['pole_pairs'] = str(self.pole_pairs)
        meta['points'] = str(self.points)
        out = [f'# {k}: {v}' for k, v in meta.items()]
        out.append(HEADER)
        data = np.column_stack([self.columns[c] for c in COLUMNS])
        out.extend(','.join(repr(float(v)) for v in row) for row in data)
        Path(path).write_text('\n'.join(out) + '\n')

    # ----------------------------------------------------------------- scalar lookups
    def lookup_index(self, theta: float) -> tuple[int, float]:
        """(row, fraction) of the linear, wrapped interpolation at theta [rad] (rows of ``points``)."""
        x = theta * self._scale
        i = math.floor(x)
        frac = x - i
        i %= self.points
        return i, frac

    def k_alpha_beta(self, theta: float) -> tuple[float, float]:
        """(k_alpha, k_beta) [V*s/rad] at electrical angle theta [rad] (linear, wrapped)."""
        # lookup_index inlined: the torque estimate calls this every sample.
        x = theta * self._scale
        i = math.floor(x)
        f = x - i
        i %= self.points
        ka, kb = self._kal, self._kbe
        return ka[i] + f * (ka[i + 1] - ka[i]), kb[i] + f * (kb[i + 1] - kb[i])

    def k_abc(self, theta: float) -> tuple[float, float, float]:
        """(k_a, k_b, k_c) [V*s/rad] at theta [rad]."""
        i, f = self.lookup_index(theta)
        a, b, c = self._ka, self._kb, self._kc
        return (a[i] + f * (a[i + 1] - a[i]), b[i] + f * (b[i + 1] - b[i]), c[i] + f * (c[i + 1] - c[i]))

    def k_phase(self, phase: int, theta: float) -> float:
        """k of phase 0/1/2 (a/b/c) [V*s/rad] at theta [rad]."""
        i, f = self.lookup_index(theta)
        col = (self._ka, self._kb, self._kc)[phase]
        return col[i] + f * (col[i + 1] - col[i])

    def rotor_flux(self, theta: float) -> tuple[float, float]:
        """(psi_r_alpha, psi_r_beta) [Wb]: integral of k over theta, zero mean (eq. 2.19's phi_r)."""
        i, f = self.lookup_index(theta)
        a, b = self._psia, self._psib
        return a[i] + f * (a[i + 1] - a[i]), b[i] + f * (b[i + 1] - b[i])

    def rotor_flux_magnitude(self, theta: float) -> float:
        """|psi_r(theta)| [Wb]: the position-dependent stator flux reference of eq. (2.20)/(4.3)."""
        i, f = self.lookup_index(theta)
        m = self._psim
        return m[i] + f * (m[i + 1] - m[i])

    def interp(self, column: str, theta) -> np.ndarray:
        """Vectorised linear, wrapped interpolation of a column (for analysis and tests)."""
        th = np.mod(np.asarray(theta, dtype=float), TWO_PI)
        grid = np.append(self.columns['theta_e'], TWO_PI)
        vals = np.append(self.columns[column], self.columns[column][0])
        return np.interp(th, grid, vals)


def periodic_list(values) -> list:
    """Python floats with a wrap-around copy of the first value (for linear, wrapped lookups)."""
    values = [float(v) for v in values]
    return values + [values[0]]


def _integrate_zero_mean(k: np.ndarray) -> np.ndarray:
    """Periodic integral of k over theta (trapezoidal on the grid), mean removed."""
    n = len(k)
    h = TWO_PI / n
    nxt = np.roll(k, -1)
    cum = np.concatenate(([0.0], np.cumsum(0.5 * h * (k + nxt))[:-1]))
    return cum - cum.mean()


def _check_consistency(name: str, cols: dict) -> None:
    """Evenly spaced angles over [0, 2 pi) and derived columns matching the per-phase ones."""
    theta = cols['theta_e']
    n = len(theta)
    if n < 6:
        raise BackEmfTableError(f'{name}: needs at least 6 points, has {n}')
    expected = np.arange(n) * (TWO_PI / n)
    bad = np.flatnonzero(np.abs(theta - expected) > 1e-6 * TWO_PI / n + 1e-9)
    if bad.size:
        j = int(bad[0])
        raise BackEmfTableError(f'{name}: theta_e not evenly spaced over [0, 2*pi): row {j + 1} is '
                                f'{theta[j]!r}, expected {expected[j]!r}')
    scale = max(1e-12, float(np.max(np.abs(np.column_stack([cols['k_a'], cols['k_b'], cols['k_c']])))))
    tol = 1e-4 * scale + 1e-12  # allows ~6 significant digits in the file
    k_a, k_b, k_c = cols['k_a'], cols['k_b'], cols['k_c']
    derived = {
        'k_ba': k_b - k_a, 'k_ca': k_c - k_a,
        'k_alpha': (2.0 * k_a - k_b - k_c) / 3.0, 'k_beta': (k_b - k_c) * INV_SQRT3,
    }
    derived['k_d'] = derived['k_alpha'] * np.cos(theta) + derived['k_beta'] * np.sin(theta)
    derived['k_q'] = -derived['k_alpha'] * np.sin(theta) + derived['k_beta'] * np.cos(theta)
    for col, want in derived.items():
        err = np.abs(cols[col] - want)
        if np.max(err) > tol:
            j = int(np.argmax(err))
            raise BackEmfTableError(f'{name}: column {col} does not match the per-phase columns at row '
                                    f'{j + 1} (got {cols[col][j]!r}, convention gives {want[j]!r})')
