"""The plant's stepping thread: lockstep channels, pipelining, command waits and their faults.

docs/architecture.md "Time and lockstep": per base tick the plant publishes the due
controllers' measurements, waits for their commands (pipelined: the previous due sample's),
latches them and integrates a tick. A command missing past ``command_timeout``, or one the plant
cannot apply, means the safe state until the controller answers again (docs/faults.md).
Commands are received only by this thread (:class:`~drive_common.lockstep_io.DirectReceiver`).
"""
from __future__ import annotations

import struct
import time
from dataclasses import dataclass, field
from functools import partial
from typing import Any, Callable

import rclpy
from diagnostic_msgs.msg import DiagnosticStatus

from bldc_plant_sim.core.faults import FaultKind, run_end
from bldc_plant_sim.core.lockstep import ControllerKind
from bldc_plant_sim.core.plant import PlantCore
from drive_common import topics
from drive_common.conversions import sec_nanosec
from drive_common.lockstep_io import DirectCallbackGroup, DirectReceiver
from drive_common.lockstep_wire import LockstepWire
from drive_common.peer_binding import PeerBinding
from drive_common.samples import DriveSample, DutySample, GateSample, PfcSample
from dtc_msgs.action import Run
from dtc_msgs.msg import DriveMeasurement, DutyCommand, GateCommand, PfcMeasurement, PlantState

COMMAND_TIMEOUT = PlantState.PROTECTION_COMMAND_TIMEOUT
FAULTED_GLANCE = 5e-4           # s a controller that fell silent is waited for per due sample
WAIT_LOG_FIRST, WAIT_LOG_PERIOD = 1.0, 5.0   # s: first and later "waiting for ..." log lines


class StartupFailed(Exception):
    """A controller due in the run did not become ready within startup_timeout."""


def _invalid_duty(msg, core: PlantCore) -> str | None:
    """Why a duty command cannot be applied (NaN, infinite or outside [0, 1]), or None."""
    return None if 0.0 <= msg.duty <= 1.0 else f'duty command with duty = {msg.duty!r}, outside [0, 1]'


@dataclass(frozen=True)
class ChannelSpec:
    """The ROS side of one controller kind: topics, message and sample types, conversions."""

    node: str                                   # the controller node that answers
    measurement_topic: str
    measurement_type: type
    measurement_sample: type
    command_topic: str
    command_type: type
    command_sample: type
    sample_of: Callable[[PlantCore], Any]       # the measurement sample at t_k
    command_of: Callable[[Any], tuple]          # message -> LockstepSchedule command
    invalid: Callable[[Any, PlantCore], str | None]   # why a command cannot be applied, or None

    @property
    def controller(self) -> str:
        """Who answers, for log lines: node (measurement topic -> command topic)."""
        return f'{self.node} ({self.measurement_topic} -> {self.command_topic})'


CHANNELS = {
    ControllerKind.GATE: ChannelSpec(
        'dtc_controller',
        topics.DRIVE_MEASUREMENT, DriveMeasurement, DriveSample,
        topics.GATE_COMMAND, GateCommand, GateSample, PlantCore.drive_sample,
        lambda msg: tuple(bool(s) for s in msg.switch_on),
        lambda msg, core: core.wrong_topology(msg.topology)),   # switch_on is bool[6] by its type
    ControllerKind.DUTY: ChannelSpec(
        'pfc_controller',
        topics.PFC_MEASUREMENT, PfcMeasurement, PfcSample,
        topics.DUTY_COMMAND, DutyCommand, DutySample, PlantCore.pfc_sample,
        lambda msg: (float(msg.duty), bool(msg.enable)), _invalid_duty),
}
"""Per controller kind, everything the plant node needs to know of its lockstep topics."""


class WaitReporter:
    """Logs what the plant waits for (limit: what bounds the wait, for the log line)."""

    def __init__(self, logger, limit: str) -> None:
        self._logger, self._limit = logger, limit
        self._start = time.monotonic()
        self._next = self._start + WAIT_LOG_FIRST

    def report(self, what: str) -> None:
        now = time.monotonic()
        if now >= self._next:
            self._next = now + WAIT_LOG_PERIOD
            self._logger.info(f'waiting {now - self._start:.0f} s {self._limit} for {what}')


@dataclass
class _Channel:
    """One controller's side of the lockstep: its endpoints, commands and the one being computed."""

    kind: ControllerKind
    spec: ChannelSpec
    binding: PeerBinding                        # the controller whose commands are taken
    publisher: Any                              # of the measurements (raw CDR bytes)
    wire: LockstepWire                          # measurement sample -> CDR bytes
    subscription: Any = None                    # of the commands (received by the stepping thread)
    awaiting: tuple[int, float] | None = None   # pipelined: (step, deadline) of the pending command
    last_sent: bytes = b''                      # the last measurement, serialized
    commands: dict = field(default_factory=dict)   # latest command message per step

    def take(self, step: int):
        """The command message of step, or None; older ones are dropped as stale."""
        msg = self.commands.pop(step, None)
        if msg is not None or len(self.commands) > 64:
            for stale in [s for s in self.commands if s < step]:
                del self.commands[stale]
        return msg

    def send(self, data: bytes) -> None:
        """Publish a measurement (kept for a resend to a controller that matched late)."""
        self.last_sent = data
        self.publisher.publish(data)


class LockstepLoop:
    """Mixin of :class:`~bldc_plant_sim.plant_node.PlantNode`: the stepping thread's work."""

    def _open_lockstep(self) -> None:
        """One channel per controller kind; the commands are received only by the stepping thread."""
        direct = DirectCallbackGroup()
        self._channels: dict[ControllerKind, _Channel] = {}
        for kind, spec in CHANNELS.items():
            publisher = self.create_publisher(spec.measurement_type, spec.measurement_topic,
                                              topics.LOCKSTEP_QOS)
            binding = PeerBinding(self, spec.command_topic, spec.measurement_topic,
                                  report=partial(self._diagnose, DiagnosticStatus.WARN),   # intruders
                                  may_bind=lambda: self._conflict is None)
            channel = _Channel(kind, spec, binding, publisher,
                               LockstepWire(spec.measurement_type, spec.measurement_sample))
            channel.subscription = self.create_subscription(
                spec.command_type, spec.command_topic, self._receive(channel),
                topics.LOCKSTEP_READER_QOS, callback_group=direct, raw=True)
            self._channels[kind] = channel
        self._receiver = DirectReceiver(self.context, [c.subscription for c in self._channels.values()],
                                        with_publisher=True)

    def _scheduled_channels(self) -> list[_Channel]:
        """The channels of the controllers in the run (a period of at least one tick)."""
        return [c for c in self._channels.values() if c.kind.ticks(self.schedule)]

    def _halted(self) -> str | None:
        """Why the run must end now (stop, shutdown, a second graph), or None."""
        return 'plant shutting down' if self._interrupted() else self._conflict

    def _interrupted(self) -> bool:
        """The node is being stopped (Ctrl-C, SIGTERM, stop()): a clean end, logged at INFO."""
        return self._stopping.is_set() or not rclpy.ok(context=self.context)

    def _await(self, channel: _Channel, step: int, deadline: float | None):
        """The command for step, waiting until deadline (None: FAULTED_GLANCE from now)."""
        msg = channel.take(step)
        if msg is None and deadline is None:
            deadline = time.monotonic() + FAULTED_GLANCE
        while msg is None:
            remaining = deadline - time.monotonic()
            if remaining <= 0.0 or self._halted():
                self._receiver.poll(0.0)
                return channel.take(step)
            self._receiver.poll(min(remaining, 0.05))
            msg = channel.take(step)
        return msg

    def _first_answer(self, channel: _Channel, k: int) -> Any:
        """Wait up to startup_timeout for a controller's first answer, re-sending the measurement
        every topics.FIRST_ANSWER_RESEND s (one sent before the reader matched is lost)."""
        timeout = self.parameters['startup_timeout']
        deadline = self._run_started + timeout      # the whole start-up shares one timeout
        while True:
            msg = self._await(channel, k, min(deadline, time.monotonic() + topics.FIRST_ANSWER_RESEND))
            if msg is not None:
                return msg
            halted = self._halted()
            if halted:
                raise StartupFailed(halted)
            if time.monotonic() >= deadline:
                raise StartupFailed(f'{channel.spec.controller} did not answer its first measurement '
                                     f'(step {k}) within startup_timeout = {timeout:g} s')
            self._startup_report.report(f'{channel.spec.controller} to answer its first measurement '
                                        f'(step {k})')
            channel.send(channel.last_sent)

    def run_to(self, target_step: int, goal_handle=None) -> tuple[bool, str]:
        """Advance to target_step (held there); (success, message)."""
        self._running, self._target_step = True, target_step
        self._faults: list[str] = []
        faults_before = list(self.core.faults.counts)
        self.last_run_end = None
        self._start_failed = False
        first_step = self.core.step
        try:
            self._run_started = time.monotonic()
            timeout = self.parameters['startup_timeout']
            self._startup_report = WaitReporter(self.get_logger(), f'of startup_timeout = {timeout:g} s')
            reason = self._wait_for_peers(self._run_started + timeout, self._startup_report)
            if reason:
                return False, self._startup_failed(reason)
            self._startup_pending = {c.kind for c in self._scheduled_channels()} - self._ready
            for which, reason in self._faulted.items():
                if reason is not None and which not in self._startup_pending:
                    self._faults.append(f'safe state continues ({which}): {reason}')
            self._pipelined = self.schedule.computation_delay and self.parameters['pipelined']
            started, start_time = time.monotonic(), self.core.time
            feedback_every = max(1, int(0.05 / self.core.base_tick))
            while self.core.step < target_step:
                if goal_handle is not None and goal_handle.is_cancel_requested:
                    self._drain()
                    return False, f'cancelled at t = {self.core.time:.6f} s'
                halted = self._halted()
                if halted:
                    return False, f'{halted} at t = {self.core.time:.6f} s'
                self._apply_pending()
                try:
                    self._tick()
                except StartupFailed as exc:
                    return False, self._startup_failed(str(exc))
                if self.core.faults.pending:
                    self.faults.flush()
                if goal_handle is not None and self.core.step % feedback_every == 0:
                    wall = time.monotonic() - started
                    goal_handle.publish_feedback(Run.Feedback(
                        sim_time=self.core.time, step=self.core.step,
                        real_time_factor=(self.core.time - start_time) / wall if wall > 0 else 0.0))
            self._drain()
            self._publish_state_once()
            reached = f'reached t = {self.core.time:.6f} s (step {self.core.step})'
            if self._faults:
                return False, f'{reached} with faults: ' + '; '.join(self._faults[:3])
            end = run_end(self.core, faults_before)
            if end.faulted:
                return False, f'{reached}, {end.end_state}'
            return True, reached
        finally:
            if not self._interrupted():      # (publishing fails once the context is shut down)
                self.faults.flush()
                for channel in self._channels.values():
                    channel.binding.flush()    # an intruder that sent and left, by gid
            self.last_run_end = run_end(self.core, faults_before)
            self.last_run_started = not self._start_failed or self.core.step != first_step
            # A run that ends otherwise (stop, second graph, failed start-up) drops the
            # pending commands: the next run re-publishes a sample it did not finish.
            for channel in self._channels.values():
                channel.awaiting = None
            self._telemetry.flush()     # sim time holds: a bag taken now has every sample
            self._running = False

    def _drain(self) -> None:
        """Pipelined: receive every outstanding command before the time holds."""
        for channel in self._channels.values():
            self._collect(channel)

    def _command(self, channel: _Channel, k: int, deadline: float):
        """The due, valid command of one controller, or None (safe state): its first in a run
        waits for readiness; a silent or invalid one is faulted once, until a valid command
        (a silent one is then waited for only FAULTED_GLANCE per due sample)."""
        which = channel.kind
        if which in self._startup_pending:
            msg = self._first_answer(channel, k)
            self._startup_pending.discard(which)
        else:
            msg = self._await(channel, k, None if which in self._silent else deadline)
            if msg is None and self._halted():
                return None           # the run ends (Ctrl-C, shutdown): no command is missing
        reason = (f'no {which} command for step {k} within {self.parameters["command_timeout"]} s'
                  if msg is None else channel.spec.invalid(msg, self.core))
        if reason is not None:
            if self._faulted[which] is None or (msg is not None and self._faulted[which] != reason):
                self._fault(which, reason, FaultKind.INVALID_COMMAND if msg is not None
                            else FaultKind.COMMAND_TIMEOUT)
                self._faulted[which] = reason
            (self._silent.add if msg is None else self._silent.discard)(which)
            self._ready.discard(which)
            return None
        self._ready.add(which)
        self._silent.discard(which)
        if self._faulted[which]:
            self._faulted[which] = None
            if not any(self._faulted.values()):
                self.core.leave_safe_state(COMMAND_TIMEOUT)
            if self._fault_shown.get(which):     # the fault it ends was reported
                self._diagnose(DiagnosticStatus.OK, f'{which} commands resumed at step {k}', {})
        return msg

    def _receive(self, channel: _Channel):
        """The raw callback of a command topic: decode into channel.commands; an undecodable one is
        dropped as a malformed_command fault (its step then times out)."""
        spec = channel.spec
        wire = LockstepWire(spec.command_type, spec.command_sample)

        def receive(data: bytes, publisher: bytes) -> None:
            if not channel.binding.accepts(publisher):
                return                       # not the bound controller: ignored (reported once)
            try:
                command = wire.decode(data)[0]
            except (ValueError, struct.error) as exc:
                self.faults.report(FaultKind.MALFORMED_COMMAND,
                                   f'{spec.command_topic}: malformed message dropped: {exc}',
                                   self._sources(channel.kind), {'controller': channel.kind.value})
                return
            channel.commands[command.step] = command
        return receive

    def _tick(self) -> None:
        """One base tick of the lockstep protocol."""
        k = self.core.step
        if self._first_clock_due():
            # The first /clock waits (up to FIRST_CLOCK_ACK_WAIT) for its readers, before any
            # measurement goes out.
            self._publish_state_once()
        due = [c for c in self._channels.values() if self.schedule.is_due(c.kind, k)]
        if due:
            sec, nanosec = sec_nanosec(self.core.time)
            for channel in due:
                sample = channel.spec.sample_of(self.core)
                sample.hold_after = self.schedule.holds_after(channel.kind, k, self._target_step)
                channel.send(channel.wire.encode(sample, sec, nanosec))
        # Ground truth at t_k goes out while the controllers compute their answers.
        self._publish_state_once()
        deadline = time.monotonic() + self.parameters['command_timeout']
        for channel in due:
            self._serve(channel, k, deadline)
        self.core.advance()

    def _serve(self, channel: _Channel, k: int, deadline: float) -> None:
        """Latch what a controller due at tick k commands from k on: command k (sequential), or
        (pipelined) the previous due sample's, command k left to compute meanwhile."""
        if self._pipelined and channel.kind not in self._startup_pending:
            self._collect(channel)
            self.schedule.apply_held(self.core, channel.kind)
            channel.awaiting = (k, deadline)
            return
        msg = self._command(channel, k, deadline)
        if msg is not None:
            self.schedule.latch(self.core, channel.kind, channel.spec.command_of(msg))

    def _collect(self, channel: _Channel) -> None:
        """Pipelined: receive the outstanding command of a controller (if any) and hold it."""
        if channel.awaiting is None:
            return
        (step, deadline), channel.awaiting = channel.awaiting, None
        msg = self._command(channel, step, deadline)
        if msg is not None:
            self.schedule.hold(channel.kind, channel.spec.command_of(msg))

    def _startup_failed(self, reason: str) -> str:
        """Sim time did not start (it holds, so no safe state is needed); report why."""
        self._start_failed = True
        if self._interrupted():
            self.get_logger().info(f'run not started: {reason}')
            return reason
        self._diagnose(DiagnosticStatus.ERROR, f'run not started: {reason}',
                       {'sim_time': f'{self.core.time:.9f}', 'step': str(self.core.step)})
        self.get_logger().error(f'run not started: {reason}')
        return reason

    def _fault(self, which: ControllerKind, reason: str, kind: FaultKind) -> None:
        """Safe state and a fault report naming the commanding node(s), also in the goal's result."""
        self.core.enter_safe_state(COMMAND_TIMEOUT)
        sources = self._sources(which)
        if kind == FaultKind.COMMAND_TIMEOUT and sources.startswith('no publisher'):
            kind = FaultKind.LOST_CONTROLLER
        reason = f'{reason} (from {sources})'
        shown = self.faults.report(kind, f'{reason}: safe state entered', sources,
                                   {'controller': which.value})
        self._fault_shown[which] = shown
        if shown or not self._faults:     # a goal with a fault never ends successful
            self._faults.append(f'safe state at t = {self.core.time:.6f} s: {reason}'
                                + ('' if shown else ' (a repeated fault; reports rate-limited)'))
