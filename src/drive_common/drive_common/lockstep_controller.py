"""ROS node base of the lockstep controllers (controller authors: :mod:`drive_common.controller_api`).

Answers each measurement of step k with the core's command of step k (a repeated one with
the same command), swaps accepted parameter changes in at the next sample, and publishes
status blocks and the decimated live status (docs/architecture.md "Time and lockstep",
"Telemetry: blocks and live topics").
"""
from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any, Callable

from rclpy.node import Node

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from drive_common.conversions import ReusedMessage
from drive_common.domain_guard import wait_for_stable_graph
from drive_common.lockstep_io import (DirectCallbackGroup, DirectReceiver, GraphConflict,
                                      graph_conflict, readers_matched)
from drive_common.lockstep_wire import LockstepWire
from drive_common.parameters import ParameterError, ParameterSchema
from drive_common.peer_binding import PeerBinding
from drive_common.ros_parameters import SchemaParameters
from drive_common.telemetry import DEFAULT_BLOCK_SIZE, DEFAULT_LIVE_PERIOD
from drive_common.telemetry_blocks import BlockStream
from drive_common.samples import DriveSample
from drive_common.topics import (BLOCK_QOS, DIAGNOSTICS, DRIVE_MEASUREMENT, DTC_STATUS, DTC_STATUS_BLOCK,
                                 GATE_COMMAND, LIVE_QOS, LOCKSTEP_QOS, LOCKSTEP_READER_QOS)
from drive_common.waiting import wait_until


__all__ = ['LockstepChannels', 'LockstepControllerNode', 'gate_channels']

GRAPH_CHECK_PERIOD = 0.5   # s between checks for a second graph in the domain
STOP_WAIT = 5.0            # s stop() waits for the answering thread
POLL = 0.1                 # s per wait for measurements (the stop flag is checked between)
MATCH_WAIT = 5.0           # s the first answer waits for the telemetry readers to match


@dataclass(frozen=True)
class LockstepChannels:
    """Message types and topics of one lockstep controller."""

    measurement_type: type
    measurement_topic: str
    sample_type: type            # core dataclass built from the measurement
    command_type: type
    command_topic: str
    status_type: type | None     # None: the controller publishes no status
    status_topic: str
    block_type: type | None = None   # status block (telemetry_blocks.BLOCK_PARTS); None: none
    block_topic: str = ''


def gate_channels(status: bool = True) -> LockstepChannels:
    """The channels of a drive controller: drive/measurement in, drive/gate_command out and,
    with status, dtc/status and dtc/status_block."""
    from dtc_msgs.msg import DriveMeasurement, DtcStatus, DtcStatusBlock, GateCommand
    return LockstepChannels(DriveMeasurement, DRIVE_MEASUREMENT, DriveSample, GateCommand, GATE_COMMAND,
                            DtcStatus if status else None, DTC_STATUS,
                            DtcStatusBlock if status else None, DTC_STATUS_BLOCK)


class LockstepControllerNode(Node):
    """Measurement in, command + status out, one core update per sample.

    make_core(snapshot): the core, or ParameterError/ValueError/OSError to refuse;
    check(snapshot): validates a change (default: the core's ``check``, else make_core).
    """

    def __init__(self, node_name: str, *, schema: ParameterSchema,
                 make_core: Callable[[dict[str, Any]], Any],
                 channels: LockstepChannels, check: Callable[[dict[str, Any]], Any] | None = None,
                 **kwargs) -> None:
        super().__init__(node_name, **kwargs)
        self._channels = channels
        self._lock = threading.Lock()
        self._pending: dict[str, Any] | None = None
        # Parameter events: sim time of the last answered sample (its command, stamped before sending).
        self.parameters = SchemaParameters(self, schema, on_change=self._on_parameters, sim_time=lambda: (
            None if self._last_stamp is None else Time(sec=self._last_stamp[0],
                                                       nanosec=self._last_stamp[1])))
        try:
            self.core = make_core(dict(self.parameters.values))
        except (ParameterError, ValueError, OSError) as exc:
            raise ParameterError(str(exc)) from exc
        self._check = check or getattr(self.core, 'check', None) or make_core
        self.samples_answered = 0
        self._command_pub = self.create_publisher(channels.command_type, channels.command_topic,
                                                  LOCKSTEP_QOS)
        self._status_pub = (self.create_publisher(channels.status_type, channels.status_topic,
                                                  LIVE_QOS) if channels.status_type else None)
        self._block_pub = (self.create_publisher(channels.block_type, channels.block_topic,
                                                 BLOCK_QOS) if channels.block_type else None)
        self._measurement_wire = LockstepWire(channels.measurement_type, channels.sample_type)
        self._command_wire: LockstepWire | None = None    # built for the core's command type
        self._status_msg = ReusedMessage(channels.status_type) if channels.status_type else None
        self._telemetry = BlockStream(channels.block_type,
                                      self._block_pub.publish if self._block_pub else None,
                                      *self._telemetry_settings(self.parameters.values))
        self._last_measurement = self._last_command = self._last_stamp = None   # bytes, bytes, (sec, ns)
        self._diag_pub = self.create_publisher(DiagnosticArray, DIAGNOSTICS, 10)
        self._conflict: str | None = None     # a second graph found: refuse to run (exit 2)
        self._binding = PeerBinding(self, channels.measurement_topic, channels.command_topic,
                                    report=self._diagnose_intruder,
                                    may_bind=lambda: self._graph_conflict() is None)
        self._receiver = DirectReceiver(self.context, [self.create_subscription(
            channels.measurement_type, channels.measurement_topic, self._on_peer_message,
            LOCKSTEP_READER_QOS, callback_group=DirectCallbackGroup(), raw=True)],
            with_publisher=True)
        self.create_timer(GRAPH_CHECK_PERIOD, self._check_graph)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._answer_samples, daemon=True,
                                        name=f'{node_name}_lockstep')
        self._thread.start()

    def _answer_samples(self) -> None:
        import rclpy
        # Discovery first: a node started late in a running graph must refuse, not bind.
        if not wait_for_stable_graph(self, stop=lambda: self._stop.is_set()
                                     or not rclpy.ok(context=self.context)):
            return
        while not self._stop.is_set() and rclpy.ok(context=self.context):
            try:
                self._receiver.poll(POLL)
            except Exception as exc:  # noqa: BLE001 - shutdown races end the loop quietly
                if self._stop.is_set() or not rclpy.ok(context=self.context):
                    return
                raise exc

    def _check_graph(self) -> None:
        """Bound to a plant: report intruders; else a second graph in the domain: exit 2."""
        self._binding.check()
        if self._binding.bound:
            return
        reason = not self._stop.is_set() and (self._conflict or self._graph_conflict())
        if reason:
            self._stop.set()
            raise GraphConflict(reason)      # once: run_node reports it and exits 2

    def _graph_conflict(self) -> str | None:
        """A second graph in the domain (kept: the check timer makes the node exit 2), or None."""
        self._conflict = self._conflict or graph_conflict(
            self, (self._channels.command_topic, self._channels.measurement_topic))
        return self._conflict

    def stop(self) -> None:
        """End the answering thread and wait for it (before the node is destroyed)."""
        self._stop.set()
        self._thread.join(timeout=STOP_WAIT)
        try:
            self._binding.flush()        # an intruder that sent and left, by gid
            self._telemetry.flush()
        except Exception:  # noqa: BLE001 - the context may already be shut down
            pass

    def destroy_node(self) -> None:
        self.stop()
        super().destroy_node()

    def _on_parameters(self, snapshot: dict[str, Any]) -> None:
        """Validate a change against the core now; apply it at the next sample."""
        try:
            self._check(dict(snapshot))
        except (ValueError, OSError) as exc:
            raise ParameterError(str(exc)) from exc
        with self._lock:
            self._pending = snapshot

    def _on_peer_message(self, data: bytes, publisher: bytes) -> None:
        """A measurement from the bound plant (binding it if none is); others are ignored."""
        if self._binding.accepts(publisher):
            self._on_measurement(data)

    def _diagnose_intruder(self, message: str, values: dict[str, str]) -> None:
        """An intruder on a lockstep topic, once (WARN on /diagnostics)."""
        stamp = self._last_stamp or (0, 0)
        status = DiagnosticStatus(level=DiagnosticStatus.WARN, name=f'{self.get_name()}: lockstep',
                                  message=message, hardware_id=self.get_name(),
                                  values=[KeyValue(key=k, value=v) for k, v in values.items()])
        array = DiagnosticArray(status=[status])
        array.header.stamp = Time(sec=stamp[0], nanosec=stamp[1])
        self._diag_pub.publish(array)

    def _on_measurement(self, data: bytes) -> None:
        """One serialized measurement: core update, command out, then telemetry."""
        if data == self._last_measurement:
            self._command_pub.publish(self._last_command)   # a re-sent sample: same answer
            return
        if not self.samples_answered:
            self._match_telemetry_readers()
        with self._lock:
            pending, self._pending = self._pending, None
        if pending is not None:
            self.core.reconfigure(pending)
            self._telemetry.retune(*self._telemetry_settings(pending))
        sample, sec, nanosec = self._measurement_wire.decode(data)
        command, status = self.core.update(sample)
        wire = self._command_wire
        if wire is None or type(command) is not wire.sample_type:
            wire = self._command_wire = LockstepWire(self._channels.command_type, type(command))
        self._last_command = wire.encode(command, sec, nanosec)
        self._command_pub.publish(self._last_command)
        self._last_measurement, self._last_stamp = data, (sec, nanosec)
        if self._status_pub is not None and status is not None:   # None: no status for this sample
            self._publish_status(status, sample, command, sec, nanosec)
        if sample.hold_after:
            self._telemetry.flush()      # the plant holds sim time after this sample
        self.samples_answered += 1

    def _match_telemetry_readers(self) -> None:
        """Before the first answer: wait (at most MATCH_WAIT s) until every reader of the
        telemetry topics already in the graph is matched, or it would miss the first samples."""
        publishers = [p for p in (self._status_pub, self._block_pub) if p is not None]
        if not wait_until(lambda: readers_matched(self, publishers) or self._stop.is_set(),
                          MATCH_WAIT, 0.01, raise_timeout=False):
            self.get_logger().warning('some telemetry subscribers were not matched '
                                      'before the first sample')

    @staticmethod
    def _telemetry_settings(values) -> tuple[int, float]:
        """(telemetry.block_size, telemetry.live_period) of a snapshot, or the defaults."""
        return (values.get('telemetry.block_size', DEFAULT_BLOCK_SIZE),
                values.get('telemetry.live_period', DEFAULT_LIVE_PERIOD))

    def _publish_status(self, status, measurement, command, sec: int, nanosec: int) -> None:
        """The sample into the status block (published when full); the live status if kept."""
        if self._telemetry.append(sec * 1_000_000_000 + nanosec, status, measurement, command):
            self._status_pub.publish(self._status_msg.fill(status, stamp=Time(sec=sec,
                                                                              nanosec=nanosec)))
