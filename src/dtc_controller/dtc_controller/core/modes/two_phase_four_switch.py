"""Four-switch two-phase BLDC DTC, phase c on the split-capacitor midpoint (000 ch. IV).

Sectors I, III, IV, VI: Table IV. Sectors II and V: the phase-a and phase-b
torques (eq. 4.4) by separate comparators, T_ea* = T_eb* = T*/2, band
torque_band / split_band_divisor, vectors per the derived Table V; CW inverts
CCW. A line-to-line table has no zero sequence, so the split-phase torques use
k_a' = (k_a - k_b)/2, k_b' = -k_a' (a common term that leaves the total torque
unchanged and makes T_ea' = T_eb' mean i_c = 0). Why: docs/models.md
"Four-switch two-phase mode".
"""
from __future__ import annotations

from ..switching_tables import derive_split_phase_table, split_phase_sectors
from ..vectors import four_switch_vectors
from .two_phase_base import TwoPhaseModeBase

MIDPOINT_PHASE = 2  # phase c


class TwoPhaseFourSwitchMode(TwoPhaseModeBase):
    name = 'two_phase_four_switch'
    topology = 4
    midpoint_phase = MIDPOINT_PHASE

    def make_vectors(self):
        return four_switch_vectors(MIDPOINT_PHASE)

    def split_phase_tables(self) -> dict:
        """Table V for both rotations in sectors II and V (module doc)."""
        self.split_sectors = split_phase_sectors(self.tables[1], MIDPOINT_PHASE)
        self.split_tables = {r: derive_split_phase_table(self.vectors, MIDPOINT_PHASE, self.split_sectors, r)
                             for r in (1, -1)}
        return self.split_tables

    def split_band(self, params: dict) -> float:
        """torque_band / split_band_divisor [N m] (1000 in the seed)."""
        return float(params['torque_band']) / float(params['four_switch.split_band_divisor'])
