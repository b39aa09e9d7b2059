"""Rotor position: encoder angle and hall-sector detection (docs/architecture.md conventions).

Hall x reads 1 while the fundamental of k_x(theta_e) = -sin(theta_e - shift_x) is positive;
hall_code = H_a | H_b << 1 | H_c << 2; the six valid codes each cover a 60-deg interval between
back-EMF zero crossings.
"""
from __future__ import annotations

import math

from drive_common.signals import PHASE_SHIFT, TWO_PI, wrap_angle


def encoder_angle(count: int, counts_per_rev: int, pole_pairs: int, offset: float = 0.0) -> float:
    """Electrical angle [rad] in [0, 2 pi) from a quadrature count (counts per mechanical rev)."""
    return wrap_angle(pole_pairs * TWO_PI * count / counts_per_rev + offset)


def hall_code_at(theta: float) -> int:
    """Hall code the convention gives at electrical angle theta [rad]."""
    code = 0
    for x in range(3):
        if -math.sin(theta - PHASE_SHIFT[x]) > 0.0:
            code |= 1 << x
    return code


def _derive_hall_intervals() -> dict:
    out = {}
    for n in range(6):
        start = n * math.pi / 3.0
        out[hall_code_at(start + math.pi / 6.0)] = (n + 1, start, start + math.pi / 3.0)
    return out


HALL_INTERVALS = _derive_hall_intervals()
"""hall code -> (hall sector 1..6, start angle, end angle) [rad]; sector 1 = [0, 60) deg."""


def hall_sector(code: int) -> int:
    """Hall sector 1..6 (60-deg interval starting at (sector-1)*60 deg); 0 for invalid codes 0/7."""
    entry = HALL_INTERVALS.get(code)
    return entry[0] if entry else 0


def hall_angle(code: int) -> float:
    """Centre angle [rad] of the hall interval of code, NaN for invalid codes (coarse position)."""
    entry = HALL_INTERVALS.get(code)
    return 0.5 * (entry[1] + entry[2]) if entry else float('nan')
