"""What every DTC mode regulates alike: the torque and flux hysteresis, the speed PI and their references.

Torque reference T* (parameter, or the speed PI's output when ``speed_loop.enabled``),
flux reference, rotation (selects the switching table ``table_now`` of ``self.tables``),
two-level torque / flux comparators with half-width bands and the speed PI gains.
Runtime changes act from the next sample.
"""
from __future__ import annotations

from ..hysteresis import TwoLevelHysteresis
from ..speed_loop import SpeedPI


class DtcRegulation:
    """Mixin of the mode base classes; the mode provides ``tables`` {rotation: table}."""

    def _build_regulators(self, params: dict) -> None:
        """The torque and flux comparators and the speed PI (references follow in apply_runtime)."""
        self.torque_hyst = TwoLevelHysteresis(params['torque_band'])
        self.flux_hyst = TwoLevelHysteresis(params['flux_band'])
        self.speed_pi = SpeedPI(params['speed_loop.kp'], params['speed_loop.ki'],
                                params['speed_loop.period_samples'], params['sample_period'],
                                params['speed_loop.torque_limit'])

    def _apply_references(self, params: dict) -> None:
        """Rotation and its table, torque / flux references and bands, speed loop and PI gains."""
        self.rotation = int(params['rotation'])
        self.table_now = self.tables[self.rotation]
        self.torque_reference = float(params['torque_reference'])
        self.torque_hyst.band = float(params['torque_band'])
        self.flux_hyst.band = float(params['flux_band'])
        self.flux_reference = float(params['flux_reference'])
        self.speed_loop = bool(params['speed_loop.enabled'])
        self.speed_reference = float(params['speed_reference'])
        self.speed_pi.set_gains(params['speed_loop.kp'], params['speed_loop.ki'],
                                params['speed_loop.period_samples'], params['speed_loop.torque_limit'])
