"""The ``plant`` node: lockstep time master over the ROS-agnostic PlantCore.

DESIGN.md §3. Sim time only advances inside a ``plant/run`` action goal (or
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

Threading: the lockstep publishers and subscriptions live on a private
child node that no executor spins; the stepping thread waits on the command
subscriptions directly (:class:`drive_common.lockstep_io.DirectReceiver`,
no executor hand-off per sample); the action server, services and
parameters are served by the node's own executor in other threads.
"""
from __future__ import annotations

import threading
import time
from typing import Any

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock

from bldc_plant_sim.core.lockstep import LockstepSchedule
from bldc_plant_sim.core.plant import PlantCore
from bldc_plant_sim.parameters import PLANT_NODE_SCHEMA, effective_params
from drive_common import topics
from drive_common.conversions import ReusedMessage, time_msg
from drive_common.node_main import run_node
from drive_common.lockstep_io import DirectReceiver
from drive_common.parameters import ParameterError
from drive_common.ros_parameters import SchemaParameters
from dtc_msgs.action import Run
from dtc_msgs.msg import (DriveMeasurement, DutyCommand, GateCommand, PfcMeasurement,
                          PlantState)
from dtc_msgs.srv import ResetProtection

COMMAND_TIMEOUT = PlantState.PROTECTION_COMMAND_TIMEOUT
AUTORUN_DISCOVERY_DELAY = 1.0   # s of wall time before run_until starts the run


class _Inbox:
    """Latest command per step from one controller (filled by the stepping thread's receiver)."""

    def __init__(self) -> None:
        self.commands: dict[int, Any] = {}

    def put(self, msg) -> None:
        self.commands[msg.step] = msg

    def take(self, step: int):
        msg = self.commands.pop(step, None)
        if msg is not None or len(self.commands) > 64:
            # Anything older than the awaited step is stale: never applied.
            for stale in [s for s in self.commands if s < step]:
                del self.commands[stale]
        return msg


class PlantNode(Node):
    """Lockstep plant: see the module docstring."""

    def __init__(self, **kwargs) -> None:
        super().__init__('plant', **kwargs)
        self._running = False
        self._faulted: dict[str, str | None] = {'gate': None, 'duty': None}   # why, per controller
        self._faults: list[str] = []
        self._pending: dict[str, Any] | None = None
        self._lock = threading.Lock()
        self.parameters = SchemaParameters(self, PLANT_NODE_SCHEMA, on_change=self._on_parameters,
                                           is_running=lambda: self._running)
        explicit = {n for n in PLANT_NODE_SCHEMA.names() if n in self._parameter_overrides}
        try:
            params = effective_params(self.parameters.values, explicit=explicit)
            self.core = PlantCore(params)
        except (ValueError, OSError) as exc:
            raise ParameterError(f'plant: cannot start: {exc}') from exc
        self.schedule = LockstepSchedule.from_params(params, self.core.base_tick)
        # The declared parameters show the values in use (a motor file's included) ...
        self._set_atomically({n: v for n, v in params.items() if v != self.parameters.values[n]})
        # ... and a later motor.file change brings the file's values with it, atomically.
        self.add_pre_set_parameters_callback(self._with_motor_file_values)

        # Lockstep side: private node + executor, spun only by the stepping thread.
        self._io = rclpy.create_node('plant_lockstep', context=self.context,
                                     namespace=self.get_namespace(),
                                     start_parameter_services=False)
        qos = topics.LOCKSTEP_QOS
        self._drive_pub = self._io.create_publisher(DriveMeasurement, topics.DRIVE_MEASUREMENT, qos)
        self._pfc_pub = self._io.create_publisher(PfcMeasurement, topics.PFC_MEASUREMENT, qos)
        self._gates_in, self._duty_in = _Inbox(), _Inbox()
        self._receiver = DirectReceiver(self.context, [
            self._io.create_subscription(GateCommand, topics.GATE_COMMAND, self._gates_in.put, qos),
            self._io.create_subscription(DutyCommand, topics.DUTY_COMMAND, self._duty_in.put, qos)])
        self._state_pub = self.create_publisher(PlantState, topics.PLANT_STATE, topics.STREAM_QOS)
        self._clock_pub = self.create_publisher(Clock, topics.CLOCK, topics.STREAM_QOS)
        self._drive_msg = ReusedMessage(DriveMeasurement)
        self._pfc_msg = ReusedMessage(PfcMeasurement)
        self._state_msg = ReusedMessage(PlantState)
        self._state_lock = threading.Lock()
        self._diag_pub = self.create_publisher(DiagnosticArray, topics.DIAGNOSTICS, 10)

        self._run_group = MutuallyExclusiveCallbackGroup()
        self._action = ActionServer(self, Run, topics.RUN_ACTION, execute_callback=self._execute,
                                    goal_callback=self._accept_goal,
                                    cancel_callback=lambda _: CancelResponse.ACCEPT,
                                    callback_group=self._run_group)
        self.create_service(ResetProtection, topics.RESET_PROTECTION_SERVICE, self._reset,
                            callback_group=ReentrantCallbackGroup())
        self._state_sent_step = -1   # step of the last plant/state sent (never twice)
        self._autorun_timer = None
        if self.parameters['run_until'] > 0.0:
            # Give discovery a moment, so subscribers started before the plant
            # (recorders, monitors) are in the graph when sample 0 goes out.
            self._autorun_timer = self.create_timer(AUTORUN_DISCOVERY_DELAY, self._autorun,
                                                    callback_group=self._run_group)

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
        changes = {p.name: p.value for p in params if p.name in PLANT_NODE_SCHEMA}
        if not changes:
            return params
        current = self.parameters.values
        try:
            requested = PLANT_NODE_SCHEMA.validate_changes(current, changes,
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

    # --- action -----------------------------------------------------------
    def _accept_goal(self, goal) -> GoalResponse:
        target = goal.target_time
        if not (target == target) or target < 0.0:  # NaN or negative
            self.get_logger().warning(f'Run goal rejected: target_time {target} must be >= 0')
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def _autorun(self) -> None:
        self._autorun_timer.cancel()
        ok, message = self.run_to(self.core.step_of(self.parameters['run_until']))
        self.get_logger().info(f'run_until finished: {message}')

    def _execute(self, goal_handle):
        goal = goal_handle.request
        target_time = goal.target_time + (self.core.time if goal.relative else 0.0)
        target_step = self.core.step_of(target_time)
        ok, message = self.run_to(target_step, goal_handle)
        result = Run.Result(success=ok, final_step=self.core.step, final_time=self.core.time,
                            message=message)
        if goal_handle.is_cancel_requested:
            goal_handle.canceled()
        elif ok:
            goal_handle.succeed()
        else:
            goal_handle.abort()
        return result

    # --- stepping ---------------------------------------------------------
    def _wait_for_peers(self, timeout: float) -> str | None:
        """Wait until every required controller is matched; None or the reason it failed."""
        deadline = time.monotonic() + timeout
        needs = []
        if self.schedule.dtc_ticks:
            needs += [(self._drive_pub.get_subscription_count, 'dtc_controller on drive/measurement'),
                      (lambda: self._io.count_publishers(topics.GATE_COMMAND), 'dtc_controller on drive/gate_command')]
        if self.schedule.pfc_ticks:
            needs += [(self._pfc_pub.get_subscription_count, 'pfc_controller on pfc/measurement'),
                      (lambda: self._io.count_publishers(topics.DUTY_COMMAND), 'pfc_controller on pfc/duty_command')]
        while True:
            missing = [what for count, what in needs if count() < 1]
            if not missing:
                break
            if time.monotonic() > deadline:
                return 'no controller matched: ' + ', '.join(missing)
            self._receiver.poll(0.01)
        # Every other subscriber already in the graph (a recorder, a monitor) must be
        # matched too before sample 0 goes out, or it would miss the first samples.
        outputs = [(self._drive_pub, self._io), (self._pfc_pub, self._io), (self._state_pub, self)]
        while any(pub.get_subscription_count() < node.count_subscribers(pub.topic_name)
                  for pub, node in outputs):
            if time.monotonic() > deadline:
                self.get_logger().warning('some subscribers were not matched before the run')
                break
            self._receiver.poll(0.01)
        return None

    def _await(self, inbox: _Inbox, step: int, deadline: float | None):
        """The command for step, waiting until deadline (None: only what has arrived)."""
        msg = inbox.take(step)
        while msg is None:
            remaining = 0.0 if deadline is None else deadline - time.monotonic()
            if remaining <= 0.0:
                self._receiver.poll(0.0)
                return inbox.take(step)
            self._receiver.poll(min(remaining, 0.05))
            msg = inbox.take(step)
        return msg

    def run_to(self, target_step: int, goal_handle=None) -> tuple[bool, str]:
        """Advance to target_step (held there); (success, message)."""
        self._running = True
        self._faults: list[str] = []
        try:
            reason = self._wait_for_peers(self.parameters['startup_timeout'])
            if reason:
                self._fault('startup', reason)
                return False, reason
            for which, reason in self._faulted.items():
                if reason is not None:   # faulted in an earlier goal and not answered since
                    self._faults.append(f'safe state continues ({which}): {reason}')
            started, start_time = time.monotonic(), self.core.time
            feedback_every = max(1, int(0.05 / self.core.base_tick))
            while self.core.step < target_step:
                if goal_handle is not None and goal_handle.is_cancel_requested:
                    return False, f'cancelled at t = {self.core.time:.6f} s'
                if not rclpy.ok(context=self.context):
                    return False, 'plant shutting down'
                self._apply_pending()
                self._tick()
                if goal_handle is not None and self.core.step % feedback_every == 0:
                    wall = time.monotonic() - started
                    goal_handle.publish_feedback(Run.Feedback(
                        sim_time=self.core.time, step=self.core.step,
                        real_time_factor=(self.core.time - start_time) / wall if wall > 0 else 0.0))
            self._publish_state_once()
            reached = f'reached t = {self.core.time:.6f} s (step {self.core.step})'
            if self._faults:
                return False, f'{reached} with faults: ' + '; '.join(self._faults[:3])
            return True, reached
        finally:
            self._running = False

    def _command(self, which: str, inbox: _Inbox, k: int, deadline: float,
                 invalid=lambda msg: None):
        """The due, valid command of one controller, or None (safe state).

        A controller that stays silent past the deadline, or sends a command
        the plant cannot apply (``invalid(msg)`` returns the reason), is
        faulted once: safe state, diagnostic, and no more waiting for it
        until it sends a valid command for a due sample again.
        """
        msg = self._await(inbox, k, None if self._faulted[which] else deadline)
        reason = (f'no {which} command for step {k} within {self.parameters["command_timeout"]} s'
                  if msg is None else invalid(msg))
        if reason is not None:
            # Report a new fault once; a controller that stays silent is not re-reported.
            if self._faulted[which] is None or (msg is not None and self._faulted[which] != reason):
                self._fault(which, reason)
                self._faulted[which] = reason
            return None
        if self._faulted[which]:
            self._faulted[which] = None
            if not any(self._faulted.values()):
                self.core.leave_safe_state(COMMAND_TIMEOUT)
            self._diagnose(DiagnosticStatus.OK, f'{which} commands resumed at step {k}', {})
        return msg

    def _wrong_topology(self, msg) -> str | None:
        if msg.topology != self.core.topology:
            return (f'gate command for a {msg.topology}-switch inverter, the plant has '
                    f'{self.core.topology}')
        return None

    def _tick(self) -> None:
        """One base tick of the lockstep protocol."""
        k = self.core.step
        due_dtc, due_pfc = self.schedule.due(k)
        if due_dtc:
            self._drive_pub.publish(self._drive_msg.fill(self.core.drive_sample(), self.core.time))
        if due_pfc:
            self._pfc_pub.publish(self._pfc_msg.fill(self.core.pfc_sample(), self.core.time))
        # Ground truth at t_k goes out while the controllers compute their answers.
        self._publish_state_once()
        deadline = time.monotonic() + self.parameters['command_timeout']
        if due_dtc:
            msg = self._command('gate', self._gates_in, k, deadline, self._wrong_topology)
            if msg is not None:
                self.schedule.latch_gates(self.core, tuple(bool(s) for s in msg.switch_on))
        if due_pfc:
            msg = self._command('duty', self._duty_in, k, deadline)
            if msg is not None:
                self.schedule.latch_duty(self.core, float(msg.duty), bool(msg.enable))
        self.core.advance()

    def _publish_state_once(self) -> None:
        """plant/state and /clock at t_k, for every state_ticks-th step, each step once."""
        step = self.core.step
        if step != self._state_sent_step and step % self.schedule.state_ticks == 0:
            self._state_sent_step = step
            self._publish_state()

    def _publish_state(self) -> None:
        with self._state_lock:   # the reset service publishes from an executor thread
            self._state_pub.publish(self._state_msg.fill(self.core.state(), self.core.time))
        clock_ticks = self.schedule.clock_ticks
        if clock_ticks == 0 or self.core.step % clock_ticks == 0:
            self._clock_pub.publish(Clock(clock=time_msg(self.core.time)))

    def _fault(self, which: str, reason: str) -> None:
        """Safe state with a diagnostic; the fault is reported in the goal's result."""
        self.core.enter_safe_state(COMMAND_TIMEOUT)
        self._faults.append(f'safe state at t = {self.core.time:.6f} s: {reason}')
        self._diagnose(DiagnosticStatus.ERROR, f'safe state: {reason}',
                       {'sim_time': f'{self.core.time:.9f}', 'step': str(self.core.step),
                        'controller': which})
        self.get_logger().error(f'safe state applied: {reason}')

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
        self._publish_state()
        return response

    def destroy_node(self) -> None:
        self._io.destroy_node()
        super().destroy_node()


def main(args=None) -> int:
    return run_node(PlantNode, args, multithreaded=True)


if __name__ == '__main__':
    raise SystemExit(main())
