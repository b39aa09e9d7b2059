"""Four-switch two-phase BLDC DTC, phase c on the split-capacitor midpoint (000 ch. IV).

Sectors I, III, IV, VI: Table IV. Sectors II and V: the phase-a and phase-b torques (eq. 4.4) by
separate comparators, T_ea* = T_eb* = T*/2, band torque_band / split_band_divisor, vectors per the
derived Table V, with k_a' = (k_a - k_b)/2, k_b' = -k_a' (T_ea' = T_eb' means i_c = 0). Why:
docs/models.md "Four-switch two-phase mode".
"""
from __future__ import annotations

from ..switching_tables import derive_split_phase_table, split_phase_sectors
from ..vectors import four_switch_vectors
from . import two_phase_kernel as K
from .two_phase_base import TwoPhaseModeBase

MIDPOINT_PHASE = 2  # phase c


class TwoPhaseFourSwitchMode(TwoPhaseModeBase):
    """``two_phase_four_switch``: see the module doc."""

    name = 'two_phase_four_switch'
    topology = 4
    midpoint_phase = MIDPOINT_PHASE

    def make_vectors(self):
        return four_switch_vectors(MIDPOINT_PHASE)

    def split_phase_tables(self) -> dict:
        """Table V for both rotations in sectors II and V (module doc)."""
        sectors = split_phase_sectors(self.tables[1], MIDPOINT_PHASE)
        return {r: derive_split_phase_table(self.vectors, MIDPOINT_PHASE, sectors, r) for r in (1, -1)}

    def configure(self, params: dict) -> None:
        """The two-phase parameters, then the split-phase band torque_band / split_band_divisor [N m]."""
        super().configure(params)
        divisor = float(params['four_switch.split_band_divisor'])
        self._prm[K.P_SPLIT_BAND] = float(params['torque_band']) / divisor
