"""Reference-frame transforms (docs/architecture.md conventions), scalar and fast.

Clarke, amplitude-invariant (the dissertation's eq. (1.21) scaled by 2/3):
``x_alpha = (2 x_a - x_b - x_c) / 3``, ``x_beta = (x_b - x_c) / sqrt(3)``.
Park: ``x_d = x_alpha cos(theta) + x_beta sin(theta)``,
``x_q = -x_alpha sin(theta) + x_beta cos(theta)``.
All functions take and return plain floats (no numpy per sample).
"""
from __future__ import annotations

import math

TWO_PI = 2.0 * math.pi
SQRT3 = math.sqrt(3.0)
INV_SQRT3 = 1.0 / SQRT3
PHASE_SHIFT = (0.0, TWO_PI / 3.0, 2.0 * TWO_PI / 3.0)
"""rad: phase x quantities are functions of theta_e - PHASE_SHIFT[x] (a, b, c)."""


def clarke(x_a: float, x_b: float, x_c: float) -> tuple[float, float]:
    """(alpha, beta) of a three-phase set (amplitude-invariant; zero sequence dropped)."""
    return (2.0 * x_a - x_b - x_c) / 3.0, (x_b - x_c) * INV_SQRT3


def clarke_balanced(x_a: float, x_b: float) -> tuple[float, float]:
    """(alpha, beta) from two phases of a zero-sum set (x_c = -x_a - x_b)."""
    return x_a, (x_a + 2.0 * x_b) * INV_SQRT3


def inverse_clarke(x_alpha: float, x_beta: float) -> tuple[float, float, float]:
    """(a, b, c) of an alpha/beta pair with zero zero-sequence."""
    h = 0.5 * SQRT3 * x_beta
    return x_alpha, -0.5 * x_alpha + h, -0.5 * x_alpha - h


def park(x_alpha: float, x_beta: float, theta: float) -> tuple[float, float]:
    """(d, q) in the frame at electrical angle theta [rad]."""
    c = math.cos(theta)
    s = math.sin(theta)
    return x_alpha * c + x_beta * s, -x_alpha * s + x_beta * c


def inverse_park(x_d: float, x_q: float, theta: float) -> tuple[float, float]:
    """(alpha, beta) of a d/q pair in the frame at theta [rad]."""
    c = math.cos(theta)
    s = math.sin(theta)
    return x_d * c - x_q * s, x_d * s + x_q * c


def line_to_line_constants(k_a: float, k_b: float, k_c: float) -> tuple[float, float]:
    """(k_ba, k_ca) = (k_b - k_a, k_c - k_a): the dissertation's measured line-to-line pair."""
    return k_b - k_a, k_c - k_a


def alpha_beta_from_line_to_line(x_ba: float, x_ca: float) -> tuple[float, float]:
    """(alpha, beta) of a zero-sequence-free set from (x_b - x_a, x_c - x_a).

    With x_a + x_b + x_c = 0: x_a = -(x_ba + x_ca)/3, so alpha = x_a and
    beta = (x_b - x_c)/sqrt(3) = (x_ba - x_ca)/sqrt(3). This is the
    architecture-convention form of the dissertation's line-to-line
    transformation (2.17), which uses another scaling.
    """
    return -(x_ba + x_ca) / 3.0, (x_ba - x_ca) * INV_SQRT3


def wrap_angle(theta: float) -> float:
    """theta wrapped to [0, 2 pi) rad."""
    theta = math.fmod(theta, TWO_PI)
    if theta < 0.0:
        theta += TWO_PI
    if theta >= TWO_PI:  # fmod of a tiny negative number
        theta = 0.0
    return theta


def reconstruct_currents(i_a: float, i_b: float, i_c: float) -> tuple[float, float, float]:
    """Phase currents [A] with at most one NaN (missing sensor) filled from i_a + i_b + i_c = 0.

    Raises ValueError when two or more currents are missing.
    """
    if i_a == i_a and i_b == i_b and i_c == i_c:  # fast path: no NaN
        return i_a, i_b, i_c
    if i_a != i_a:
        if i_b != i_b or i_c != i_c:
            raise ValueError('at least two phase currents are NaN: cannot reconstruct')
        return -i_b - i_c, i_b, i_c
    if i_b != i_b:
        if i_c != i_c:
            raise ValueError('at least two phase currents are NaN: cannot reconstruct')
        return i_a, -i_a - i_c, i_c
    return i_a, i_b, -i_a - i_b
