"""The back-EMF table file of the generator test (000 §5.4): columns, read, write.

Format and rules: docs/architecture.md "Back-EMF table file"; every k in V*s/rad (Wb),
``e = omega_e * k(theta_e)``. Every error is a :class:`BackEmfTableError` ``<path>:<line>: ...``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from drive_common import file_cache
from drive_common.signals import TWO_PI, clarke, park

__all__ = ['COLUMNS', 'HEADER', 'REQUIRED_COLUMNS', 'MIN_TABLE_ROWS', 'BackEmfTableError', 'TableFile',
           'columns_from_phases', 'columns_from_line_to_line', 'periodic_integral', 'periodic_list', 'read', 'write']

COLUMNS = ('theta_e', 'k_a', 'k_b', 'k_c', 'k_ba', 'k_ca', 'k_alpha', 'k_beta', 'k_d', 'k_q')
HEADER = ','.join(COLUMNS)
REQUIRED_COLUMNS = ('theta_e', 'k_ba', 'k_ca')
MIN_TABLE_ROWS = 12
"""Fewest data rows: one per 30 electrical degrees, the corner spacing of the 120-degree
trapezoid (fewer rows cannot describe a six-step waveform)."""


class BackEmfTableError(ValueError):
    """A back-EMF table file is malformed or does not fit the motor; the message names file and line."""


@dataclass
class TableFile:
    """What :func:`read` found: columns by header name, ``# key: value`` metadata, source lines."""

    path: str
    columns: dict
    metadata: dict
    header_line: int
    row_lines: list


def columns_from_phases(k_a, k_b, k_c) -> dict:
    """Every column from per-phase constants sampled at theta_e = 2 pi n / N."""
    k_a, k_b, k_c = (np.asarray(x, dtype=float) for x in (k_a, k_b, k_c))
    theta = np.arange(len(k_a)) * (TWO_PI / len(k_a))
    k_alpha, k_beta = clarke(k_a, k_b, k_c)
    k_d, k_q = park(k_alpha, k_beta, theta)
    return {'theta_e': theta, 'k_a': k_a, 'k_b': k_b, 'k_c': k_c, 'k_ba': k_b - k_a, 'k_ca': k_c - k_a,
            'k_alpha': k_alpha, 'k_beta': k_beta, 'k_d': k_d, 'k_q': k_q}


def columns_from_line_to_line(k_ba, k_ca) -> dict:
    """Every column from the measured line-to-line pair (000 eq. (5.13): no zero sequence)."""
    k_ba, k_ca = np.asarray(k_ba, float), np.asarray(k_ca, float)
    k_a = -(k_ba + k_ca) / 3.0
    cols = columns_from_phases(k_a, k_a + k_ba, k_a + k_ca)
    cols['k_ba'], cols['k_ca'] = k_ba, k_ca
    return cols


def periodic_integral(k) -> np.ndarray:
    """Zero-mean periodic integral over theta_e of samples on the grid 2 pi n / N, along the last axis.

    Trapezoidal rule; the rotor flux psi_r [Wb] from k = d psi_r / d theta_e (000 eqs. (2.19), (E.1)).
    """
    k = np.asarray(k, dtype=float)
    steps = 0.5 * (TWO_PI / k.shape[-1]) * (k + np.roll(k, -1, axis=-1))
    cum = np.concatenate((np.zeros(k.shape[:-1] + (1,)), np.cumsum(steps, axis=-1)[..., :-1]), axis=-1)
    return cum - cum.mean(axis=-1, keepdims=True)


def periodic_list(values) -> list:
    """Python floats with a wrap-around copy of the first value (for linear, wrapped scalar lookups)."""
    values = [float(v) for v in values]
    return values + [values[0]]


def _fail(path, line: int, reason: str) -> BackEmfTableError:
    return BackEmfTableError(f'{path}:{line}: {reason}')


def read(path) -> TableFile:
    """Read and check a table file, once per process and file version (columns read-only)."""
    t = file_cache.from_file('backemf_file', path, lambda: _read(path))
    return TableFile(t.path, dict(t.columns), dict(t.metadata), t.header_line, list(t.row_lines))


def _read(path) -> TableFile:
    try:
        text = Path(path).read_text()
    except OSError as exc:
        raise _fail(path, 0, f'cannot read back-EMF table ({exc.strerror or exc})') from exc
    meta: dict[str, str] = {}
    header = None
    header_line = last = 0
    rows: list[list[float]] = []
    lines: list[int] = []
    for lineno, line in enumerate(text.splitlines(), start=1):
        last = lineno
        if not line.strip():
            continue
        if line.startswith('#'):
            key, colon, value = line[1:].partition(':')
            if colon and header is None:
                meta[key.strip()] = value.strip()
            continue
        if header is None:
            header = [h.strip() for h in line.split(',')]
            header_line = lineno
            for col in REQUIRED_COLUMNS:
                if col not in header:
                    raise _fail(path, lineno, f'back-EMF table header lacks column {col} '
                                              f'(header: {",".join(header)}; expected "{HEADER}")')
            continue
        cells = line.split(',')
        if len(cells) != len(header):
            raise _fail(path, lineno, f'{len(cells)} cells, the header has {len(header)}')
        row = []
        for name, cell in zip(header, cells):
            try:
                value = float(cell)
            except ValueError:
                raise _fail(path, lineno, f'column {name}: {cell.strip()!r} is not a number') from None
            if not math.isfinite(value):
                raise _fail(path, lineno, f'column {name}: {cell.strip()!r} is not finite')
            row.append(value)
        rows.append(row)
        lines.append(lineno)
    if header is None:
        raise _fail(path, last, f'no header line in back-EMF table (expected "{HEADER}")')
    if len(rows) < MIN_TABLE_ROWS:
        raise _fail(path, lines[-1] if lines else header_line,
                    f'{len(rows)} data row(s); a back-EMF table needs at least {MIN_TABLE_ROWS} '
                    'over one electrical cycle')
    if 'points' in meta and meta['points'] != str(len(rows)):
        raise _fail(path, lines[-1], f'{len(rows)} data rows, but the file says "# points: {meta["points"]}"')
    data = np.array(rows, dtype=float)
    cols = {name: file_cache.frozen(data[:, j].copy()) for j, name in enumerate(header)}
    theta = cols['theta_e']
    if theta[0] < 0.0:
        raise _fail(path, lines[0], f'theta_e {theta[0]:g} is negative; angles must lie in [0, 2 pi) rad')
    for n in range(1, len(theta)):
        if not theta[n] > theta[n - 1]:
            raise _fail(path, lines[n], f'theta_e {theta[n]:g} does not increase (previous row '
                                        f'{theta[n - 1]:g}); rows must be in strictly increasing angle')
    if theta[-1] >= TWO_PI:
        hint = ' (angles in degrees? the table wants rad)' if theta[-1] > 2.0 * TWO_PI else ''
        raise _fail(path, lines[-1], f'theta_e {theta[-1]:g} is not below 2 pi; angles must lie in '
                                     f'[0, 2 pi) rad{hint}')
    return TableFile(str(path), cols, meta, header_line, lines)


def write(path, columns: dict, metadata: dict) -> None:
    """Write a table: ``# key: value`` lines, the COLUMNS header, one row per angle (exact repr)."""
    out = [f'# {k}: {v}' for k, v in metadata.items()]
    out.append(HEADER)
    data = np.column_stack([np.asarray(columns[c], dtype=float) for c in COLUMNS])
    out.extend(','.join(repr(float(v)) for v in row) for row in data)
    Path(path).write_text('\n'.join(out) + '\n')
