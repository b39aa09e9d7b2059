"""The plant's fault record (pure Python): every fault counted, the first one latched.

docs/faults.md: a protection trip, a shoot-through request, or a controller's command that is
invalid, late or gone. The record keeps a counter per :class:`FaultKind` and the total
(PlantState ``fault_count``, ``fault_counts``), the first fault's kind, time and text, and a
bounded queue of new :class:`FaultEvent` s that the ROS node drains after each tick.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import IntEnum


class FaultKind(IntEnum):
    """Fault kinds; the values equal dtc_msgs/PlantState FAULT_* (index into fault_counts)."""

    NONE = 0
    MOTOR_OVER_CURRENT = 1     # motor phase peak-current trip (latched: all switches off)
    BOOST_OVER_CURRENT = 2     # boost inductor over-current: boost switch opened
    BOOST_OVER_VOLTAGE = 3     # boost output over-voltage: boost switch opened
    SHOOT_THROUGH = 4          # a command turned both switches of a leg on
    INVALID_COMMAND = 5        # a command the plant cannot apply (topology, duty range)
    MALFORMED_COMMAND = 6      # a command message that could not be decoded
    COMMAND_TIMEOUT = 7        # a due command did not arrive within command_timeout
    LOST_CONTROLLER = 8        # a due command did not arrive and its publisher left the graph

    @property
    def label(self) -> str:
        """The lower-case name used in logs, diagnostics, results and scenario files."""
        return self.name.lower()


PENDING_MAX = 256                     # undrained events kept (the headless runner never drains)


def fault_kind(name: str | int) -> FaultKind:
    """A FaultKind from its label (``'boost_over_current'``) or value; ValueError otherwise."""
    if isinstance(name, int) and not isinstance(name, bool):
        return FaultKind(name)
    try:
        return FaultKind[str(name).upper()]
    except KeyError:
        valid = ', '.join(k.label for k in FaultKind if k)
        raise ValueError(f'unknown fault kind {name!r} (valid: {valid})') from None


@dataclass(slots=True)
class FaultEvent:
    """One fault (or a safe-state exit, ``kind`` NONE) as it happened."""

    kind: FaultKind
    time: float                  # s, sim time
    step: int                    # plant base tick
    text: str                    # the cause, one line
    node: str = ''               # the node involved ('' = the plant itself / not known yet)
    values: dict = field(default_factory=dict)   # extra key/values (phase, leg, current, ...)


class FaultRecord:
    """Counters per kind, the first fault, and the queue of events not yet reported."""

    def __init__(self) -> None:
        self.counts = [0] * len(FaultKind)   # PlantState.fault_counts
        self.total = 0
        self.first_kind = FaultKind.NONE
        self.first_time = math.nan
        self.first_text = ''
        self.pending: list[FaultEvent] = []
        self.dropped = 0             # events not queued because the queue was full

    def record(self, kind: FaultKind, time: float, step: int, text: str, node: str = '',
               **values) -> FaultEvent:
        """Count a fault and queue it for reporting; the first one is latched."""
        kind = FaultKind(kind)
        self.counts[kind] += 1
        self.total += 1
        if self.first_kind == FaultKind.NONE:
            self.first_kind, self.first_time, self.first_text = kind, time, text
        event = FaultEvent(kind, time, step, text, node, values)
        self._queue(event)
        return event

    def note(self, time: float, step: int, text: str, **values) -> None:
        """Queue a non-fault event for reporting (a safe-state exit): not counted."""
        self._queue(FaultEvent(FaultKind.NONE, time, step, text, '', values))

    def _queue(self, event: FaultEvent) -> None:
        if len(self.pending) < PENDING_MAX:
            self.pending.append(event)
        else:
            self.dropped += 1

    def drain(self) -> list[FaultEvent]:
        """The queued events, oldest first; the queue is empty afterwards."""
        events, self.pending = self.pending, []
        return events

    def kinds_since(self, counts_before) -> tuple[str, ...]:
        """Labels of the kinds counted since the counters were counts_before."""
        return tuple(FaultKind(k).label for k, (n, n0) in enumerate(zip(self.counts, counts_before))
                     if n > n0)

    def end_state(self, total_before: int = 0, active: bool = False) -> str:
        """'ended normally', or 'ended in fault state <kind> (first fault ...)' after a fault since
        the total was total_before or with a protection / safe state active."""
        if self.total == total_before and not active:
            return 'ended normally'
        if self.first_kind == FaultKind.NONE:
            return 'ended in fault state (safe state or protection active)'
        return (f'ended in fault state {self.first_kind.label} (first fault at t = '
                f'{self.first_time:.6f} s: {self.first_text})')


@dataclass(frozen=True)
class RunEnd:
    """How a run ended (Run.Result end_state, fault_count, first_fault_time [s], first_fault,
    fault_kinds: labels of the kinds recorded during the run)."""

    end_state: str
    fault_count: int
    first_fault_time: float
    first_fault: str
    fault_kinds: tuple = ()

    @property
    def faulted(self) -> bool:
        return self.end_state != 'ended normally'


def run_end(core, counts_before: list[int]) -> RunEnd:
    """The end of a run of a PlantCore that started with core.faults.counts == counts_before."""
    record: FaultRecord = core.faults
    before = sum(counts_before)
    first = record.first_kind
    return RunEnd(record.end_state(before, bool(core.protection) or core.in_safe_state),
                  record.total - before, record.first_time, first.label if first else '',
                  record.kinds_since(counts_before))
