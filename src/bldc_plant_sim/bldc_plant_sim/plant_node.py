"""The ``plant`` node: lockstep time master over the ROS-agnostic PlantCore.

docs/architecture.md "Time and lockstep". Sim time only advances inside a ``plant/run`` action goal (or
up to the ``run_until`` parameter at start-up): for each base tick k the
node publishes the measurements of the controllers that are due (step = k),
waits for their commands carrying step k (stale or future steps are
ignored), latches them, integrates one tick and publishes ground truth and
/clock. A due command that does not arrive within ``command_timeout``
(wall clock) puts the plant in the safe state (all switches off, boost
off) and reports it on /diagnostics and in plant/state; the run goes on to
its target with the switches off (the motor coasts, currents die out
through the diodes) without waiting for the silent controller again until
it answers a due sample, and the goal then ends unsuccessful with the
reason. The node keeps serving its action, services and parameters.

Pipelined lockstep (``computation_delay`` on and ``pipelined`` true, the
default): the command of due sample k acts only from the controller's next
due sample, so at tick k the plant publishes measurement k, applies the
command of the previous due sample (waiting for it only now), and goes on
integrating while the controller computes command k. The applied commands,
hence the trajectory, equal the sequential schedule with the same delay. A
command not received within ``command_timeout`` of its measurement's publish
still puts the plant in the safe state before it would have acted. At the
end of a run (target reached or goal cancelled) the plant receives every
outstanding command, so the time holds at the target with nothing in flight
and the next goal resumes as if the run had not stopped. A controller's
first answer in a run (readiness) is awaited in turn, as without pipelining.

Start-up: sim time starts only when every controller due in the run is
matched and ready, i.e. has answered its first measurement (the plant logs
what it waits for every few seconds and gives up after ``startup_timeout``
with the reason). ``command_timeout`` and the safe state are for a
controller that stops answering during a run.

One goal at a time: a ``plant/run`` goal (or ``run_until``) that arrives
while another run holds the plant's time is rejected, and the plant logs
why. Before any controller is bound, a second graph in the domain (a second
node named ``plant``, a second publisher of a lockstep topic) makes the plant
refuse to run: the node exits with code 2 and a one-line error naming the
domain. Each command topic is bound to the controller whose command the plant
takes first (:mod:`drive_common.peer_binding`); from then on any other
publisher on the lockstep topics is ignored and reported once on
``/diagnostics`` (WARN, with its node name), never stopping or changing a run.

Threading: the lockstep publishers and subscriptions are the node's own
(``ros2 node info /plant`` lists them), but the command subscriptions are in
a :class:`~drive_common.lockstep_io.DirectCallbackGroup` that no executor
takes from: only the stepping thread receives them, waiting directly
(:class:`~drive_common.lockstep_io.DirectReceiver`, no executor hand-off
per sample). The action server, services and parameters are served by the
node's executor in other threads. :meth:`PlantNode.stop` ends a run and
waits for it before the node is destroyed (Ctrl-C at any moment).
"""
from __future__ import annotations

import struct
import threading
import time
from dataclasses import dataclass
from typing import Any, Callable

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock

from bldc_plant_sim.core.faults import FaultKind
from bldc_plant_sim.core.lockstep import LockstepSchedule
from bldc_plant_sim.core.plant import PlantCore
from bldc_plant_sim.faults_reporting import FaultReporter, RunEnd, run_end
from bldc_plant_sim.parameters import PLANT_SCHEMA, effective_params
from drive_common import topics
from drive_common.conversions import ReusedMessage, sec_nanosec, time_msg
from drive_common.domain_guard import wait_for_stable_graph
from drive_common.lockstep_io import (DirectCallbackGroup, DirectReceiver, GraphConflict,
                                      graph_conflict, readers_matched)
from drive_common.lockstep_wire import LockstepWire
from drive_common.node_main import run_node
from drive_common.parameters import ParameterError
from drive_common.peer_binding import PeerBinding
from drive_common.ros_parameters import SchemaParameters
from drive_common.samples import DriveSample, DutySample, GateSample, PfcSample
from drive_common.telemetry import nanoseconds
from drive_common.telemetry_blocks import BlockStream
from drive_common.waiting import wait_until
from dtc_msgs.action import Run
from dtc_msgs.msg import (DriveMeasurement, DutyCommand, GateCommand, PfcMeasurement,
                          PlantState, PlantStateBlock)
from dtc_msgs.srv import ResetProtection

COMMAND_TIMEOUT = PlantState.PROTECTION_COMMAND_TIMEOUT
AUTORUN_DISCOVERY_DELAY = 1.0   # s of wall time before run_until starts the run
WAIT_LOG_FIRST, WAIT_LOG_PERIOD = 1.0, 5.0   # s: first and later "waiting for ..." log lines
FIRST_ANSWER_RESEND = 2.0       # s: re-send an unanswered first measurement (lost before matching)
GRAPH_CHECK_PERIOD = 0.5        # s between checks for a second graph in the domain
FAULTED_GLANCE = 5e-4           # s of wall time a controller that fell silent is waited for per
                                # due sample: one that answers again resumes; a dead one slows little
STOP_WAIT = 10.0                # s stop() waits for a run to end
LOCKSTEP_TOPICS = (topics.DRIVE_MEASUREMENT, topics.PFC_MEASUREMENT, topics.GATE_COMMAND,
                   topics.DUTY_COMMAND)   # one publisher each, or two graphs are mixed
CONTROLLERS = {'gate': 'dtc_controller (drive/measurement -> drive/gate_command)',
               'duty': 'pfc_controller (pfc/measurement -> pfc/duty_command)'}


class _StartupFailed(Exception):
    """A controller due in the run did not become ready within startup_timeout."""


class _WaitReporter:
    """Logs what the plant waits for: after WAIT_LOG_FIRST s, then every WAIT_LOG_PERIOD s."""

    def __init__(self, logger, timeout: float) -> None:
        self._logger, self._timeout = logger, timeout
        self._start = time.monotonic()
        self._next = self._start + WAIT_LOG_FIRST

    def report(self, what: str) -> None:
        now = time.monotonic()
        if now >= self._next:
            self._next = now + WAIT_LOG_PERIOD
            self._logger.info(f'waiting {now - self._start:.0f} s of startup_timeout = '
                              f'{self._timeout:g} s for {what}')


class _Inbox:
    """Latest command per step from one controller (filled by the stepping thread's receiver).

    Only the bound controller's commands get here (``binding``, see
    drive_common.peer_binding): any other publisher's are ignored on receipt.
    """

    def __init__(self, binding: PeerBinding) -> None:
        self.commands: dict[int, Any] = {}
        self.binding = binding

    def put(self, msg) -> None:
        self.commands[msg.step] = msg

    def take(self, step: int):
        msg = self.commands.pop(step, None)
        if msg is not None or len(self.commands) > 64:
            # Anything older than the awaited step is stale: never applied.
            for stale in [s for s in self.commands if s < step]:
                del self.commands[stale]
        return msg


@dataclass
class _Channel:
    """One controller's side of the lockstep: its commands and the one still being computed."""

    which: str                                  # 'gate' (dtc_controller) or 'duty' (pfc_controller)
    inbox: _Inbox
    command_of: Callable[[Any], tuple]          # message -> LockstepSchedule command
    publish: Callable[[bytes], None]            # the measurement publisher's publish (CDR bytes)
    invalid: Callable[[Any], str | None] = lambda msg: None
    awaiting: tuple[int, float] | None = None   # pipelined: (step, deadline) of the pending command
    last_sent: bytes = b''                      # the last measurement, serialized

    def send(self, data: bytes) -> None:
        """Publish a measurement (and keep it for resend)."""
        self.last_sent = data
        self.publish(data)

    def resend(self) -> None:
        """Publish the last measurement again (start-up: a controller that matched late)."""
        self.publish(self.last_sent)


def _unknown_node(name: str, namespace: str) -> bool:
    """A graph endpoint of a node the graph no longer knows (rmw placeholder names)."""
    return name.startswith('_NODE_NAME_UNKNOWN') or namespace.startswith('_NODE_NAMESPACE_UNKNOWN')


def _gate_command(msg) -> tuple:
    return tuple(bool(s) for s in msg.switch_on)


def _duty_command(msg) -> tuple:
    return float(msg.duty), bool(msg.enable)


class PlantNode(Node):
    """Lockstep plant: see the module docstring."""

    def __init__(self, **kwargs) -> None:
        super().__init__('plant', **kwargs)
        self._running = False
        self._busy = threading.Lock()        # held by the one run (goal or run_until) at a time
        self._stopping = threading.Event()   # set by stop(): the run ends at the next tick
        self._conflict: str | None = None    # a second graph in the domain: refuse to run
        self._refused = False
        self._ready: set[str] = set()        # controllers that answered since they last failed
        self._startup_pending: set[str] = set()
        self._faulted: dict[str, str | None] = {'gate': None, 'duty': None}   # why, per controller
        self._silent: set[str] = set()       # faulted by a timeout: FAULTED_GLANCE per sample
        self._fault_shown: dict[str, bool] = {}   # per controller: its last fault was shown
        self.last_run_end: RunEnd | None = None    # how the last run ended (Run.Result fields)
        self._faults: list[str] = []
        self._last_sources: dict[str, str] = {}   # which -> the command publishers last seen
        self._pending: dict[str, Any] | None = None
        self._lock = threading.Lock()
        self.parameters = SchemaParameters(self, PLANT_SCHEMA, on_change=self._on_parameters,
                                           is_running=lambda: self._running, sim_time=lambda: self.core.time)
        explicit = {n for n in PLANT_SCHEMA.names() if n in self._parameter_overrides}
        try:
            params = effective_params(self.parameters.values, explicit=explicit)
            self.core = PlantCore(params)
        except (ValueError, OSError) as exc:
            raise ParameterError(str(exc)) from exc   # run_node says 'cannot start'
        self.schedule = LockstepSchedule.from_params(params, self.core.base_tick)
        # The declared parameters show the values in use (a motor file's included) ...
        self._set_atomically({n: v for n, v in params.items() if v != self.parameters.values[n]})
        # ... and a later motor.file change brings the file's values with it, atomically.
        self.add_pre_set_parameters_callback(self._with_motor_file_values)

        # Lockstep side: the commands are received only by the stepping thread.
        qos, direct = topics.LOCKSTEP_QOS, DirectCallbackGroup()
        self._drive_pub = self.create_publisher(DriveMeasurement, topics.DRIVE_MEASUREMENT, qos)
        self._pfc_pub = self.create_publisher(PfcMeasurement, topics.PFC_MEASUREMENT, qos)
        # Each command topic is bound to the controller that answers first (peer_binding).
        self._gates_in = _Inbox(PeerBinding(self, topics.GATE_COMMAND, topics.DRIVE_MEASUREMENT,
                                            report=self._diagnose_intruder,
                                            may_bind=lambda: self._conflict is None))
        self._duty_in = _Inbox(PeerBinding(self, topics.DUTY_COMMAND, topics.PFC_MEASUREMENT,
                                           report=self._diagnose_intruder,
                                           may_bind=lambda: self._conflict is None))
        # Measurements out and commands in as CDR bytes (drive_common.lockstep_wire).
        self._drive_wire = LockstepWire(DriveMeasurement, DriveSample)
        self._pfc_wire = LockstepWire(PfcMeasurement, PfcSample)
        self._gate_sub = self.create_subscription(
            GateCommand, topics.GATE_COMMAND,
            self._receive(self._gates_in, topics.GATE_COMMAND, GateCommand, GateSample),
            topics.LOCKSTEP_READER_QOS,
            callback_group=direct, raw=True)
        self._duty_sub = self.create_subscription(
            DutyCommand, topics.DUTY_COMMAND,
            self._receive(self._duty_in, topics.DUTY_COMMAND, DutyCommand, DutySample),
            topics.LOCKSTEP_READER_QOS,
            callback_group=direct, raw=True)
        self._receiver = DirectReceiver(self.context, [self._gate_sub, self._duty_sub],
                                        with_publisher=True)
        # Ground truth: every sample in blocks (bags), a decimated live topic (people).
        self._state_pub = self.create_publisher(PlantState, topics.PLANT_STATE, topics.LIVE_QOS)
        self._block_pub = self.create_publisher(PlantStateBlock, topics.PLANT_STATE_BLOCK,
                                                topics.BLOCK_QOS)
        self._clock_pub = self.create_publisher(Clock, topics.CLOCK, topics.LIVE_QOS)
        self._telemetry = BlockStream(PlantStateBlock, self._block_pub.publish,
                                      self.parameters['telemetry.block_size'],
                                      self.parameters['telemetry.live_period'])
        self._gate = _Channel('gate', self._gates_in, _gate_command, self._drive_pub.publish,
                              self._wrong_topology)
        self._duty = _Channel('duty', self._duty_in, _duty_command, self._pfc_pub.publish,
                              self._invalid_duty)
        self._pipelined = False              # for the run under way: see the module docstring
        self._state_msg = ReusedMessage(PlantState)
        self._state_lock = threading.RLock()
        self._diag_pub = self.create_publisher(DiagnosticArray, topics.DIAGNOSTICS, 10)
        # Every fault logged + on /diagnostics at its sim time (faults_reporting.py); also
        # the helper for faults found on the receive side: self.faults.report(kind, ...).
        self.faults = FaultReporter(self, lambda: self.core, self._diag_pub.publish,
                                    lambda kind: self._sources('gate') if kind == FaultKind.SHOOT_THROUGH
                                    else '')

        self._action = ActionServer(self, Run, topics.RUN_ACTION, execute_callback=self._execute,
                                    goal_callback=self._accept_goal,
                                    cancel_callback=lambda _: CancelResponse.ACCEPT,
                                    callback_group=MutuallyExclusiveCallbackGroup())
        self.create_service(ResetProtection, topics.RESET_PROTECTION_SERVICE, self._reset,
                            callback_group=ReentrantCallbackGroup())
        self._state_sent_step = -1   # step of the last plant/state sent (never twice)
        self._autorun_timer = None
        self._graph_settled = False          # discovery waited for before the first run
        if self.parameters['run_until'] > 0.0:
            # Give discovery a moment, so subscribers started before the plant
            # (recorders, monitors) are in the graph when sample 0 goes out.
            self._autorun_timer = self.create_timer(AUTORUN_DISCOVERY_DELAY, self._autorun,
                                                    callback_group=MutuallyExclusiveCallbackGroup())
        self.create_timer(GRAPH_CHECK_PERIOD, self._check_graph,
                          callback_group=MutuallyExclusiveCallbackGroup())

    # --- parameters -------------------------------------------------------
    def _set_atomically(self, values: dict[str, Any]) -> None:
        """Set several declared parameters in one validation (cross-checks see them together)."""
        if values:
            result = self.set_parameters_atomically([Parameter(n, value=v) for n, v in values.items()])
            if not result.successful:
                raise ParameterError(result.reason)

    def _with_motor_file_values(self, params: list[Parameter]) -> list[Parameter]:
        """Pre-set hook: a change that brings motor-file values sets them first, atomically.

        ``ros2 param set`` sends one parameter at a time and rclpy applies a list
        one by one, so the file's values (whose lists must agree in length)
        are set together here before the requested change itself.
        """
        changes = {p.name: p.value for p in params if p.name in PLANT_SCHEMA}
        if not changes:
            return params
        current = self.parameters.values
        try:
            requested = PLANT_SCHEMA.validate_changes(current, changes,
                                                           running=self._running)
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

    # --- action -----------------------------------------------------------
    def _accept_goal(self, goal) -> GoalResponse:
        """Policy: one run at a time; a goal arriving while another runs is rejected."""
        target = goal.target_time
        if not (target == target) or target < 0.0:  # NaN or negative
            self.get_logger().warning(f'Run goal rejected: target_time {target} must be >= 0')
            return GoalResponse.REJECT
        if self._stopping.is_set() or self._conflict:
            self.get_logger().warning('Run goal rejected: the plant is stopping')
            return GoalResponse.REJECT
        if not self._busy.acquire(blocking=False):   # released when the goal's run ends
            self.get_logger().warning(
                f'Run goal rejected: another run holds the plant (t = {self.core.time:.6f} s); '
                'the plant executes one plant/run goal at a time')
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def _autorun(self) -> None:
        self._autorun_timer.cancel()
        if not self._busy.acquire(blocking=False):
            self.get_logger().warning('run_until not started: a plant/run goal holds the plant')
            return
        try:
            ok, message = self.run_to(self.core.step_of(self.parameters['run_until']))
        finally:
            self._busy.release()
        end = self.last_run_end
        interrupted = self._interrupted()
        line = f'run_until finished: {message}'
        if end is not None and end.end_state not in message:
            line += f'; {end.end_state}'
        # A clean interrupt (Ctrl-C, stop()) is not an error; a fault or a failure is.
        faulted = end is not None and end.faulted
        (self.get_logger().info if (ok and not faulted) or (interrupted and not faulted)
         else self.get_logger().error)(line)

    def _execute(self, goal_handle):
        """Run a goal; it always ends: succeeded, cancelled, or aborted with the reason."""
        try:
            goal = goal_handle.request
            target_time = goal.target_time + (self.core.time if goal.relative else 0.0)
            target_step = self.core.step_of(target_time)
            try:
                ok, message = self.run_to(target_step, goal_handle)
            except Exception as exc:  # noqa: BLE001 - the goal must end with the reason
                ok, message = False, f'plant error at t = {self.core.time:.6f} s: {exc!r}'
                self.get_logger().error(f'Run goal aborted: {message}')
            end = self.last_run_end or run_end(self.core, list(self.core.faults.counts))
            result = Run.Result(success=ok, final_step=self.core.step, final_time=self.core.time,
                                message=message, end_state=end.end_state,
                                fault_count=end.fault_count, first_fault_time=end.first_fault_time,
                                first_fault=end.first_fault, fault_kinds=list(end.fault_kinds))
            if goal_handle.is_cancel_requested:
                goal_handle.canceled()
            elif ok:
                goal_handle.succeed()
            else:
                goal_handle.abort()
            return result
        finally:
            self._busy.release()             # before the client sees the result

    def _graph_conflict(self) -> str | None:
        """A second graph in the domain, or None; once a controller is bound, intruders are
        ignored and reported instead (drive_common.peer_binding)."""
        bindings = (self._gates_in.binding, self._duty_in.binding)
        if any(b.bound for b in bindings):
            for binding in bindings:
                binding.check()
            return None
        return graph_conflict(self, LOCKSTEP_TOPICS)

    def _check_graph(self) -> None:
        """A second graph in the domain: stop the run and refuse to go on (exit 2)."""
        if self._refused:
            return
        reason = self._conflict or self._graph_conflict()
        if reason:
            self._conflict, self._refused = reason, True
            raise GraphConflict(reason)      # once: run_node reports it and exits 2

    def stop(self) -> None:
        """End a run at its next tick and wait for it (before the node is destroyed)."""
        self._stopping.set()
        if self._busy.acquire(timeout=STOP_WAIT):
            self._busy.release()
        try:
            self._flush_state_block()
        except Exception:  # noqa: BLE001 - the context may already be shut down
            pass

    # --- stepping ---------------------------------------------------------
    def _halted(self) -> str | None:
        """Why the run must end now (stop, shutdown, a second graph), or None."""
        if self._stopping.is_set() or not rclpy.ok(context=self.context):
            return 'plant shutting down'
        return self._conflict

    def _wait_for_peers(self, deadline: float, report: _WaitReporter) -> str | None:
        """Wait until every required controller is matched; None or the reason it failed."""
        needs = []
        if self.schedule.dtc_ticks:
            needs += [(self._drive_pub.get_subscription_count, 'a subscriber of drive/measurement'),
                      (self._gate_sub.get_publisher_count, 'a publisher of drive/gate_command')]
        if self.schedule.pfc_ticks:
            needs += [(self._pfc_pub.get_subscription_count, 'a subscriber of pfc/measurement'),
                      (self._duty_sub.get_publisher_count, 'a publisher of pfc/duty_command')]
        while True:
            missing = [what for count, what in needs if count() < 1]
            if not missing:
                break
            halted = self._halted()
            if halted:
                return halted
            if time.monotonic() > deadline:
                return (f'no controller matched within startup_timeout = '
                        f'{self.parameters["startup_timeout"]:g} s: missing ' + ', '.join(missing))
            report.report('the controllers to start: missing ' + ', '.join(missing))
            self._receiver.poll(0.01)
        # Every other subscriber already in the graph (a recorder, a monitor) must be
        # matched too before sample 0 goes out, or it would miss the first samples; before
        # the first run, discovery of readers started earlier is done once the graph settled.
        if not self._graph_settled:
            wait_for_stable_graph(self)
            self._graph_settled = True
        outputs = [self._drive_pub, self._pfc_pub, self._state_pub, self._block_pub]
        if not wait_until(lambda: readers_matched(self, outputs) or self._halted(),
                          max(0.0, deadline - time.monotonic()), 0.01, pause=self._receiver.poll,
                          raise_timeout=False):
            self.get_logger().warning('some subscribers were not matched before the run')
        for which, due in (('gate', self.schedule.dtc_ticks), ('duty', self.schedule.pfc_ticks)):
            if due:
                self._sources(which)             # remembered, should a controller leave mid-run
        conflict = self._graph_conflict()
        if conflict:
            self._conflict = conflict            # the check timer makes the node exit 2
        return conflict

    def _await(self, inbox: _Inbox, step: int, deadline: float | None):
        """The command for step, waiting until deadline (None: FAULTED_GLANCE from now)."""
        msg = inbox.take(step)
        if msg is None and deadline is None:
            deadline = time.monotonic() + FAULTED_GLANCE
        while msg is None:
            remaining = deadline - time.monotonic()
            if remaining <= 0.0 or self._halted():
                self._receiver.poll(0.0)
                return inbox.take(step)
            self._receiver.poll(min(remaining, 0.05))
            msg = inbox.take(step)
        return msg

    def _first_answer(self, which: str, inbox: _Inbox, k: int, resend) -> Any:
        """Wait up to startup_timeout for a controller's first answer (readiness).

        A measurement published just before the controller's reader matched the
        plant's writer can be lost, so an unanswered one is re-sent every
        FIRST_ANSWER_RESEND s (a controller answers a repeated measurement from
        its cache, without a second core update).
        """
        timeout = self.parameters['startup_timeout']
        deadline = self._run_started + timeout      # the whole start-up shares one timeout
        report = self._startup_report
        while True:
            msg = self._await(inbox, k, min(deadline, time.monotonic() + FIRST_ANSWER_RESEND))
            if msg is not None:
                return msg
            halted = self._halted()
            if halted:
                raise _StartupFailed(halted)
            if time.monotonic() >= deadline:
                raise _StartupFailed(f'{CONTROLLERS[which]} did not answer its first measurement '
                                     f'(step {k}) within startup_timeout = {timeout:g} s')
            report.report(f'{CONTROLLERS[which]} to answer its first measurement (step {k})')
            resend()

    def run_to(self, target_step: int, goal_handle=None) -> tuple[bool, str]:
        """Advance to target_step (held there); (success, message)."""
        self._running = True
        self._faults: list[str] = []
        faults_before = list(self.core.faults.counts)
        self.last_run_end = None
        try:
            self._run_started = time.monotonic()
            timeout = self.parameters['startup_timeout']
            self._startup_report = _WaitReporter(self.get_logger(), timeout)
            reason = self._wait_for_peers(self._run_started + timeout, self._startup_report)
            if reason:
                return False, self._startup_failed(reason)
            scheduled = {'gate'} if self.schedule.dtc_ticks else set()
            scheduled |= {'duty'} if self.schedule.pfc_ticks else set()
            self._startup_pending = scheduled - self._ready
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
                except _StartupFailed as exc:
                    return False, self._startup_failed(str(exc))
                if self.core.faults.pending:
                    self.faults.flush()       # a trip or shoot-through in this tick: report it now
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
            if end.faulted:                   # a protection trip or a shoot-through
                return False, f'{reached}, {end.end_state}'
            return True, reached
        finally:
            if not self._interrupted():      # (publishing fails once the context is shut down)
                self.faults.flush()
            self.last_run_end = run_end(self.core, faults_before)
            # A run that ends otherwise (stop, second graph, failed start-up) drops the
            # pending commands: the next run re-publishes a sample it did not finish.
            self._gate.awaiting = self._duty.awaiting = None
            self._flush_state_block()     # sim time holds: a bag taken now has every sample
            self._running = False

    def _drain(self) -> None:
        """Pipelined: receive every outstanding command before the time holds."""
        self._collect(self._gate)
        self._collect(self._duty)

    def _command(self, channel: _Channel, k: int, deadline: float):
        """The due, valid command of one controller, or None (safe state).

        A controller's first due sample in a run, until it has answered once,
        waits for its readiness (:meth:`_first_answer`). Later, a controller
        that stays silent past the deadline, or sends a command the plant
        cannot apply (``invalid(msg)`` returns the reason), is faulted once:
        safe state, diagnostic, until it sends a valid command for a due sample
        again. A controller that answers, if wrongly, is waited for as before; one
        that fell silent only FAULTED_GLANCE per due sample.
        """
        which, inbox = channel.which, channel.inbox
        if which in self._startup_pending:
            msg = self._first_answer(which, inbox, k, channel.resend)
            self._startup_pending.discard(which)
        else:
            msg = self._await(inbox, k, None if which in self._silent else deadline)
            if msg is None and self._halted():
                return None           # the run ends (Ctrl-C, shutdown): no command is missing
        reason = (f'no {which} command for step {k} within {self.parameters["command_timeout"]} s'
                  if msg is None else channel.invalid(msg))
        if reason is not None:
            # Report a new fault once; a controller that stays silent is not re-reported.
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

    def _receive(self, inbox: _Inbox, topic: str, msg_type: type, sample_type: type):
        """The raw subscription callback of one command topic: decode, then into the inbox.

        A message that cannot be decoded is dropped and reported as a malformed_command
        fault: its step stays unanswered and the usual timeout puts the plant in the safe state.
        """
        wire = LockstepWire(msg_type, sample_type)

        def receive(data: bytes, publisher: bytes) -> None:
            if not inbox.binding.accepts(publisher):
                return                       # not the bound controller: ignored (reported once)
            try:
                command = wire.decode(data)[0]
            except (ValueError, struct.error) as exc:
                which = 'gate' if topic == topics.GATE_COMMAND else 'duty'
                self.faults.report(FaultKind.MALFORMED_COMMAND,
                                   f'{topic}: malformed message dropped: {exc}',
                                   self._sources(which), {'controller': which})
                return
            inbox.put(command)
        return receive

    def _wrong_topology(self, msg) -> str | None:
        """Why a gate command cannot be applied, or None (switch_on is bool[6] by its type)."""
        if msg.topology != self.core.topology:
            return (f'gate command for a {msg.topology}-switch inverter, the plant has '
                    f'{self.core.topology}')
        return None

    @staticmethod
    def _invalid_duty(msg) -> str | None:
        """Why a duty command cannot be applied (NaN, infinite or outside [0, 1]), or None."""
        if not 0.0 <= msg.duty <= 1.0:      # False for NaN too
            return f'duty command with duty = {msg.duty!r}, outside [0, 1]'
        return None

    def _sources(self, which: str) -> str:
        """The node(s) publishing this controller's commands, for a diagnostic (a node that
        has left the graph, e.g. a crashed controller, named as the last one seen)."""
        binding = (self._gates_in if which == 'gate' else self._duty_in).binding
        if binding.bound:
            self._last_sources[which] = binding.peer_name
            return binding.peer_name
        topic = topics.GATE_COMMAND if which == 'gate' else topics.DUTY_COMMAND
        infos = self.get_publishers_info_by_topic(topic)
        # An endpoint whose node is no longer known (it is leaving) carries placeholder
        # names (_NODE_NAME_UNKNOWN_): never shown; the last real name seen is kept.
        names = ', '.join(sorted({(i.node_namespace.rstrip('/') + '/' + i.node_name) for i in infos
                                  if not _unknown_node(i.node_name, i.node_namespace)}))
        if names:
            self._last_sources[which] = names
            return names
        last = self._last_sources.get(which) or ('unknown node' if infos else None)
        if infos:
            return f'{last} (leaving)'
        return f'no publisher; last seen: {last}, gone' if last else 'no publisher'

    def _tick(self) -> None:
        """One base tick of the lockstep protocol."""
        k = self.core.step
        due_dtc, due_pfc = self.schedule.due(k)
        if due_dtc or due_pfc:
            sec, nanosec = sec_nanosec(self.core.time)
            if due_dtc:
                self._gate.send(self._drive_wire.encode(self.core.drive_sample(), sec, nanosec))
            if due_pfc:
                self._duty.send(self._pfc_wire.encode(self.core.pfc_sample(), sec, nanosec))
        # Ground truth at t_k goes out while the controllers compute their answers.
        self._publish_state_once()
        deadline = time.monotonic() + self.parameters['command_timeout']
        if due_dtc:
            self._serve(self._gate, k, deadline)
        if due_pfc:
            self._serve(self._duty, k, deadline)
        self.core.advance()

    def _serve(self, channel: _Channel, k: int, deadline: float) -> None:
        """Latch what a controller due at tick k commands for the ticks from k on.

        Sequential: wait for command k and latch it (with computation_delay the
        schedule applies the previous one and holds this one). Pipelined: the
        previous due sample's command is received now, held and applied; command
        k is left to be computed while the plant integrates (deadline kept).
        """
        if self._pipelined and channel.which not in self._startup_pending:
            self._collect(channel)
            self.schedule.apply_held(self.core, channel.which)
            channel.awaiting = (k, deadline)
            return
        msg = self._command(channel, k, deadline)
        if msg is not None:
            self.schedule.latch(self.core, channel.which, channel.command_of(msg))

    def _collect(self, channel: _Channel) -> None:
        """Pipelined: receive the outstanding command of a controller (if any) and hold it."""
        if channel.awaiting is None:
            return
        (step, deadline), channel.awaiting = channel.awaiting, None
        msg = self._command(channel, step, deadline)
        if msg is not None:
            self.schedule.hold(channel.which, channel.command_of(msg))

    def _publish_state_once(self) -> None:
        """Ground truth and /clock at t_k, for every state_ticks-th step, each step once."""
        step = self.core.step
        if step != self._state_sent_step and step % self.schedule.state_ticks == 0:
            self._state_sent_step = step
            self._publish_state()

    def _publish_state(self) -> None:
        """Sample k into plant/state_block; plant/state if the live decimator keeps it; /clock."""
        state, stamp = self.core.state(), nanoseconds(self.core.time)
        with self._state_lock:   # the reset service publishes from an executor thread
            if self._telemetry.append(stamp, state):
                self._state_pub.publish(self._state_msg.fill(state, self.core.time))
        self._publish_clock()

    def _publish_clock(self) -> None:
        """/clock at t_k every clock_ticks steps (clock_period, default 1 ms of sim time)."""
        clock_ticks = self.schedule.clock_ticks
        if clock_ticks == 0 or self.core.step % clock_ticks == 0:
            self._clock_pub.publish(Clock(clock=time_msg(self.core.time)))

    def _flush_state_block(self) -> None:
        """Publish the partial block (sim time holds: end of a run, reset, stop)."""
        self._telemetry.flush()

    def _interrupted(self) -> bool:
        """The node is being stopped (Ctrl-C, SIGTERM, stop()): a clean end, logged at INFO."""
        return self._stopping.is_set() or not rclpy.ok(context=self.context)

    def _startup_failed(self, reason: str) -> str:
        """Sim time did not start (it holds, so no safe state is needed); report why."""
        if self._interrupted():
            self.get_logger().info(f'run not started: {reason}')
            return reason
        self._diagnose(DiagnosticStatus.ERROR, f'run not started: {reason}',
                       {'sim_time': f'{self.core.time:.9f}', 'step': str(self.core.step)})
        self.get_logger().error(f'run not started: {reason}')
        return reason

    def _fault(self, which: str, reason: str, kind: FaultKind) -> None:
        """Safe state, a fault report naming the commanding node(s) (faults_reporting.py);
        also in the goal's result. Repeats are counted, shown at most once per REPEAT_PERIOD."""
        self.core.enter_safe_state(COMMAND_TIMEOUT)
        sources = self._sources(which)
        if kind == FaultKind.COMMAND_TIMEOUT and sources.startswith('no publisher'):
            kind = FaultKind.LOST_CONTROLLER
        reason = f'{reason} (from {sources})'
        shown = self.faults.report(kind, f'{reason}: safe state entered', sources,
                                   {'controller': which})
        self._fault_shown[which] = shown
        if shown or not self._faults:     # a goal with a fault never ends successful
            self._faults.append(f'safe state at t = {self.core.time:.6f} s: {reason}'
                                + ('' if shown else ' (a repeated fault; reports rate-limited)'))

    def _diagnose_intruder(self, message: str, values: dict[str, str]) -> None:
        """Another publisher on a bound lockstep topic, once (WARN; drive_common.peer_binding)."""
        self._diagnose(DiagnosticStatus.WARN, message, values)

    def _diagnose(self, level: bytes, message: str, values: dict[str, str]) -> None:
        status = DiagnosticStatus(level=level, name='plant: lockstep', message=message,
                                  hardware_id='bldc_plant_sim',
                                  values=[KeyValue(key=k, value=v) for k, v in values.items()])
        self._diag_pub.publish(DiagnosticArray(header=self._state_header(), status=[status]))

    def _state_header(self):
        from std_msgs.msg import Header
        return Header(stamp=time_msg(self.core.time))

    def _reset(self, request, response):
        ok, message = self.core.reset_protection()
        response.success, response.message = ok, message
        self.get_logger().info(f'plant/reset_protection at t = {self.core.time:.6f} s: {message}')
        if not self._running:                # else the stepping thread reports it after its tick
            self.faults.flush()              # the safe-state exit, if the reset ended one
        # Sim time holds: the blocks are complete up to here; the reset's extra
        # sample of the same step goes out on the live topic only (a block
        # would repeat the step).
        self._flush_state_block()
        with self._state_lock:
            self._state_pub.publish(self._state_msg.fill(self.core.state(), self.core.time))
        self._publish_clock()
        return response

    def destroy_node(self) -> None:
        self.stop()
        super().destroy_node()


def main(args=None) -> int:
    return run_node(PlantNode, args, multithreaded=True)


if __name__ == '__main__':
    raise SystemExit(main())
