"""Four-switch two-phase BLDC DTC, phase c on the split-capacitor midpoint (000 ch. IV).

Sectors I, III, IV, VI: Table IV (phi = 0 row; phi = +-1 with flux control).
Sectors II and V (a and b conduct, T_ec should stay zero): phase-a and phase-b
torques (eq. 4.4, T_ex = p k_x i_x) are controlled by separate comparators
with T_ea* = T_eb* = T*/2 and band torque_band / split_band_divisor (1000 in
the seed), selecting V0/V7/V3/V6 per the derived Table V. Errors are taken in
the commanded direction, so the CW logic is the inverse of CCW.

Phase constants of the split-phase torques. Eq. (4.4) needs the true phase
back-EMF constants, zero sequence included; a table measured line-to-line
(the generator test, eq. 5.13) has the zero sequence removed, and with it
k_a != -k_b on the flat tops of a trapezoid or 1st/3rd/5th back-EMF, so
T_ea = T_eb = T*/2 would force i_c = -(i_a + i_b) != 0 -- the opposite of the
sectors' purpose (000 Table III: T_ec = 0; closed loop on the plant gave
i_c of 1-2 A). Since sum(i) = 0, any common term z(theta) may be added to all
three k without changing the total torque; we take z = (k_a + k_b)/2, i.e.
k_a' = (k_a - k_b)/2, k_b' = -k_a', so T_ea' + T_eb' = T_e exactly when
i_c = 0 and T_ea' = T_eb' means i_a = -i_b, i_c = 0. For a table with the true
phase constants of a 120-degree trapezoid (k_a = -k_b on the flat tops of
sectors II/V) this is eq. (4.4) unchanged.
"""
from __future__ import annotations

from ..hysteresis import TwoLevelHysteresis
from ..switching_tables import derive_split_phase_table, split_phase_sectors
from ..vectors import four_switch_vectors
from .two_phase_base import TwoPhaseModeBase

MIDPOINT_PHASE = 2  # phase c


class TwoPhaseFourSwitchMode(TwoPhaseModeBase):
    name = 'two_phase_four_switch'
    topology = 4
    midpoint_phase = MIDPOINT_PHASE

    def __init__(self, params, backemf) -> None:
        super().__init__(params, backemf)
        self.hyst_a = TwoLevelHysteresis(0.0)
        self.hyst_b = TwoLevelHysteresis(0.0)

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

    def configure(self, params) -> None:
        super().configure(params)
        self.hyst_a.band = self.hyst_b.band = self.split_band(params)
        self.split_now = self.split_tables[self.rotation]
