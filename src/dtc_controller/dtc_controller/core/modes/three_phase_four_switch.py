"""Four-switch three-phase DTC of a PM BLAC machine (001): ``three_phase_four_switch``.

Phase a on the split-capacitor midpoint (its terminal at the measured midpoint
voltage), legs b and c complementary: the four vectors of 001 Table I, four
90-deg flux sectors (sector I = [0, 90) deg) and 001 Table II, both derived in
:mod:`three_phase_tables`. Flux and torque as :class:`ThreePhasePmsmMode`
(001 eqs. 10-16): voltage model with a low-pass integrator (w_c = 5 rad/s, as
001's experiment) and the inverter voltage-drop compensation none / simple
(Table V) / proposed (Table VI + R_on terms, eqs. 37-38, sign of the alpha
R_on term corrected), switchable at runtime with the device drops; or the
current model (eqs. 8-9, encoder angle). Topology 4: gates SW1/SW2 are off.
"""
from __future__ import annotations

from ..three_phase_tables import four_sector_of_angle, four_switch_table
from .three_phase_pmsm import ThreePhasePmsmMode

MIDPOINT_PHASE = 0  # phase a (001 Fig. 1b)


class ThreePhaseFourSwitchMode(ThreePhasePmsmMode):
    """``three_phase_four_switch``: 001 FSTP DTC; see the module doc."""

    name = 'three_phase_four_switch'
    topology = 4
    midpoint_phase = MIDPOINT_PHASE
    default_integrator = 'low_pass'
    default_position = 'encoder'
    sectors = 4

    def make_table(self, rotation: int) -> dict:
        return four_switch_table(rotation, MIDPOINT_PHASE)

    def sector_of(self, angle: float) -> int:
        return four_sector_of_angle(angle)
