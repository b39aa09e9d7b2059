"""Hysteresis (bang-bang) comparators: two-level (eqs. 1.17-1.20).

``band`` is the half-width H [unit of the controlled quantity]: with
error = reference - actual, a two-level comparator outputs +1 once
error > +H (actual below reference - H, eq. 1.19 "d = 1") and -1 once
error < -H (eq. 1.20, written with -1 instead of 0 as Table II's tau),
holding its output in between.
"""
from __future__ import annotations

from drive_common.compiled import njit


@njit
def two_level(state: int, band: float, error: float) -> int:
    """Eqs. (1.19)-(1.20): +1 once error > +H, -1 once error < -H, else the held state."""
    if error > band:
        return 1
    if error < -band:
        return -1
    return state

