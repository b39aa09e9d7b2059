"""Hysteresis (bang-bang) comparators: two-level (eqs. 1.17-1.20).

``band`` is the half-width H [unit of the controlled quantity]: with
error = reference - actual, a two-level comparator outputs +1 once
error > +H (actual below reference - H, eq. 1.19 "d = 1") and -1 once
error < -H (eq. 1.20, written with -1 instead of 0 as Table II's tau),
holding its output in between.
"""
from __future__ import annotations

from drive_common.compiled import interpreted, njit


@njit
def two_level(state: int, band: float, error: float) -> int:
    """Eqs. (1.19)-(1.20): +1 once error > +H, -1 once error < -H, else the held state."""
    if error > band:
        return 1
    if error < -band:
        return -1
    return state


_two_level = interpreted(two_level)   # the classes' per-call path (no dispatch cost)


class TwoLevelHysteresis:
    """Output +1 / -1 with half-width band H (>= 0). ``state`` is the last output."""

    __slots__ = ('band', 'state')

    def __init__(self, band: float, initial: int = 1) -> None:
        self.band = float(band)
        self.state = 1 if initial >= 0 else -1

    def update(self, error: float) -> int:
        """New output for error = reference - actual."""
        self.state = _two_level(self.state, self.band, error)
        return self.state

    def reset(self, initial: int = 1) -> None:
        self.state = 1 if initial >= 0 else -1
