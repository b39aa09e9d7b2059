"""Motor peak-current protection (000 App. A: I_pk = 24 A).

The plant locates the instant |i_x| reaches the level inside the integration, opens all
switches there and latches until :meth:`PeakCurrentTrip.reset` (refused while still above it).
"""
from __future__ import annotations

import math

MOTOR_OVER_CURRENT = 1     # = dtc_msgs/PlantState PROTECTION_MOTOR_OVER_CURRENT
SHOOT_THROUGH = 16         # = dtc_msgs/PlantState PROTECTION_SHOOT_THROUGH (safe state, latched)


class PeakCurrentTrip:
    def __init__(self, level: float) -> None:
        self.level = float(level)      # A, 0 = disabled
        self.tripped = False
        self.trip_time = math.nan      # s, sim time of the last trip
        self.trip_current = math.nan   # A, phase current at the trip

    @property
    def enabled(self) -> bool:
        return self.level > 0.0

    def trip(self, time: float, current: float) -> None:
        self.tripped = True
        self.trip_time = time
        self.trip_current = current

    def reset(self, currents) -> tuple[bool, str]:
        if not self.tripped:
            return True, 'no protection latched'
        peak = max(abs(c) for c in currents)
        if self.enabled and peak >= self.level:
            return False, f'phase current {peak:.3f} A still at or above the trip level {self.level} A'
        self.tripped = False
        return True, f'peak-current trip (at t = {self.trip_time:.9f} s) reset'
