"""Six-switch two-phase BLDC DTC (000 ch. II, Table II, eq. 2.16).

Normal operation uses the phi = 0 row of Table II (torque hysteresis only,
tau = +-1, no zero vector); with ``flux_control.enabled`` the phi = +-1 rows
driven by a flux comparator against eq. (2.20)'s reference ("switch state 1",
kept for the seed's comparison). Table derived in switching_tables.
"""
from __future__ import annotations

from ..vectors import two_phase_six_switch_vectors
from .two_phase_base import TwoPhaseModeBase


class TwoPhaseSixSwitchMode(TwoPhaseModeBase):
    name = 'two_phase_six_switch'
    topology = 6
    midpoint_phase = None

    def make_vectors(self):
        return two_phase_six_switch_vectors()
