"""The controller's own frame helpers: Clarke from line-to-line quantities,
current reconstruction (docs/architecture.md conventions; plain floats, no numpy per sample).

Clarke/Park themselves, the angle wrap and the constants live in :mod:`drive_common.signals`.
"""
from __future__ import annotations

from drive_common.signals import INV_SQRT3


def alpha_beta_from_line_to_line(x_ba: float, x_ca: float) -> tuple[float, float]:
    """(alpha, beta) of a zero-sequence-free set from (x_b - x_a, x_c - x_a).

    With x_a + x_b + x_c = 0: x_a = -(x_ba + x_ca)/3, so alpha = x_a and
    beta = (x_b - x_c)/sqrt(3) = (x_ba - x_ca)/sqrt(3). This is the
    architecture-convention form of the dissertation's line-to-line
    transformation (2.17), which uses another scaling.
    """
    return -(x_ba + x_ca) / 3.0, (x_ba - x_ca) * INV_SQRT3


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
