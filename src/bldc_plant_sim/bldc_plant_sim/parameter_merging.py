"""The plant node's parameters: motor-file merging and changes swapped in between ticks.

The declared parameters show the values in use (a motor file's included); a ``motor.file``
change brings the file's values with it, atomically; a change is checked against the core and
applied at the next tick (docs/architecture.md "Executables, parameters and files").
"""
from __future__ import annotations

from typing import Any

from rclpy.parameter import Parameter

from bldc_plant_sim.parameters import PLANT_SCHEMA, effective_params
from drive_common.parameters import ParameterError


class ParameterMerging:
    """Mixin of :class:`~bldc_plant_sim.plant_node.PlantNode`: its parameter handling."""

    def _set_atomically(self, values: dict[str, Any]) -> None:
        """Set several declared parameters in one validation (cross-checks see them together)."""
        if values:
            result = self.set_parameters_atomically([Parameter(n, value=v) for n, v in values.items()])
            if not result.successful:
                raise ParameterError(result.reason)

    def _with_motor_file_values(self, params: list[Parameter]) -> list[Parameter]:
        """Pre-set hook: the motor-file values a change brings are set first, together (rclpy
        applies a list one by one, and the file's lists must agree in length)."""
        changes = {p.name: p.value for p in params if p.name in PLANT_SCHEMA}
        if not changes:
            return params
        current = self.parameters.values
        try:
            requested = PLANT_SCHEMA.validate_changes(current, changes, running=self._running)
            used = effective_params(requested, current)
            self._set_atomically({n: v for n, v in used.items()
                                  if v != requested[n] and n not in changes})
        except (ValueError, OSError):
            pass                   # the set callback refuses the change, with the reason
        return params

    def _on_parameters(self, snapshot: dict[str, Any]) -> None:
        """Check the new snapshot against the core; swap it in at the next tick."""
        try:
            self.core.check_params(snapshot)
        except (ValueError, OSError) as exc:
            raise ParameterError(str(exc)) from exc
        with self._lock:
            self._pending = snapshot

    def _apply_pending(self) -> None:
        with self._lock:
            pending, self._pending = self._pending, None
        if pending is not None:
            self.core.reconfigure(pending)
            self.schedule = self.schedule.updated(pending, self.core.base_tick)
            self._telemetry.retune(pending['telemetry.block_size'], pending['telemetry.live_period'])
