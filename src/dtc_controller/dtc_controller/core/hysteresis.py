"""Two-level hysteresis (bang-bang) comparators (000 eqs. 1.17-1.20).

``band`` is the half-width H; error = reference - actual; -1 stands for eq. 1.20's 0 (Table II's tau).
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
