"""ROS side of the plant's fault record: every fault logged and on /diagnostics when it happens.

docs/faults.md: the core queues faults in :class:`~bldc_plant_sim.core.faults.FaultRecord`;
the node calls :meth:`FaultReporter.flush` after each tick and :meth:`FaultReporter.report` for
faults it detects itself. Each gives an ERROR log line and a ``plant: faults`` status at its sim
time (a safe-state exit: INFO / OK); repeats of a kind are shown at most once per REPEAT_PERIOD.
"""
from __future__ import annotations

import math
from typing import Callable

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from std_msgs.msg import Header

from bldc_plant_sim.core.faults import FaultEvent, FaultKind
from drive_common.conversions import time_msg

REPEAT_PERIOD = 0.1      # s of sim time between two shown reports of one fault kind
DIAGNOSTIC_NAME = 'plant: faults'
LOCKSTEP_DIAGNOSTIC_NAME = 'plant: lockstep'   # start-up, resumed commands, intruders
HARDWARE_ID = 'bldc_plant_sim'


def diagnostic_array(name: str, level: bytes, message: str, values: dict[str, str],
                     sim_time: float) -> DiagnosticArray:
    """One plant DiagnosticStatus (hardware_id bldc_plant_sim) stamped at sim_time (s)."""
    status = DiagnosticStatus(level=level, name=name, message=message, hardware_id=HARDWARE_ID,
                              values=[KeyValue(key=k, value=v) for k, v in values.items()])
    return DiagnosticArray(header=Header(stamp=time_msg(sim_time)), status=[status])


class FaultReporter:
    """Logs and diagnoses the fault events of the core core_of() returns (module docstring);
    node_of(kind): the node a core-detected fault is attributed to ('' for the plant itself)."""

    def __init__(self, node, core_of: Callable[[], object], publish: Callable[[DiagnosticArray], None],
                 node_of: Callable[[FaultKind], str] | None = None) -> None:
        self._logger = node.get_logger()
        self._self_name = node.get_fully_qualified_name()
        self._core_of = core_of
        self._publish = publish
        self._node_of = node_of or (lambda kind: '')
        self._last_shown: dict[FaultKind, float] = {}
        self._left_out: dict[FaultKind, int] = {}

    def report(self, kind: FaultKind, message: str, node: str = '',
               values: dict[str, str] | None = None) -> bool:
        """Record a fault the node detected, at the core's sim time, and report it now; whether it
        was shown (False: a repeat within REPEAT_PERIOD, counted only)."""
        core = self._core_of()
        event = core.faults.record(kind, core.time, core.step, message, node, **(values or {}))
        return self.flush(until=event)

    def flush(self, until: FaultEvent | None = None) -> bool:
        """Log and diagnose the core's queued events; whether `until` (if given) was shown."""
        core = self._core_of()
        shown_until = False
        for event in core.faults.drain():
            shown = self._show(event)
            if event is until:
                shown_until = shown
        return shown_until

    def _show(self, event: FaultEvent) -> bool:
        if event.kind == FaultKind.NONE:       # a safe-state exit
            self._logger.info(f'{event.text} at t = {event.time:.6f} s (step {event.step})')
            self._diagnose(DiagnosticStatus.OK, event.text, event, 'safe_state_exit')
            return True
        last = self._last_shown.get(event.kind, -math.inf)
        if event.time - last < REPEAT_PERIOD:
            self._left_out[event.kind] = self._left_out.get(event.kind, 0) + 1
            return False
        self._last_shown[event.kind] = event.time
        text = event.text
        left_out = self._left_out.pop(event.kind, 0)
        if left_out:
            text += f' ({left_out} more {event.kind.label} fault(s) since the last report, not shown)'
        node = event.node or self._node_of(event.kind) or self._self_name
        self._logger.error(f'fault {event.kind.label} at t = {event.time:.6f} s (step {event.step}), '
                           f'node {node}: {text}')
        self._diagnose(DiagnosticStatus.ERROR, f'{event.kind.label}: {text}', event, event.kind.label,
                       node)
        return True

    def _diagnose(self, level: bytes, message: str, event: FaultEvent, kind: str,
                  node: str = '') -> None:
        values = {'sim_time': f'{event.time:.9f}', 'step': str(event.step), 'kind': kind,
                  'node': node or self._self_name}
        values.update({k: str(v) for k, v in event.values.items()})
        self._publish(diagnostic_array(DIAGNOSTIC_NAME, level, message, values, event.time))
