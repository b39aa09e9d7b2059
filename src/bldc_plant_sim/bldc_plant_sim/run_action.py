"""The plant's ``plant/run`` action server and its ``run_until`` start-up run.

One run at a time holds the plant's time (a goal arriving meanwhile is rejected); a goal
always ends: succeeded, cancelled, or aborted with the reason and the run's fault record.
"""
from __future__ import annotations

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup

from bldc_plant_sim.core.faults import run_end
from drive_common import topics
from dtc_msgs.action import Run

AUTORUN_DISCOVERY_DELAY = 1.0   # s of wall time before run_until starts the run


class RunAction:
    """Mixin of :class:`~bldc_plant_sim.plant_node.PlantNode`: the action server and run_until."""

    def _serve_runs(self) -> None:
        """The plant/run action server, and the run_until run after a moment of discovery."""
        self._action = ActionServer(self, Run, topics.RUN_ACTION, execute_callback=self._execute,
                                    goal_callback=self._accept_goal,
                                    cancel_callback=lambda _: CancelResponse.ACCEPT,
                                    callback_group=MutuallyExclusiveCallbackGroup())
        self._autorun_timer = None
        if self.parameters['run_until'] > 0.0:
            # A moment of discovery: subscribers started before the plant see sample 0.
            self._autorun_timer = self.create_timer(AUTORUN_DISCOVERY_DELAY, self._autorun,
                                                    callback_group=MutuallyExclusiveCallbackGroup())

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
        faulted = end is not None and end.faulted
        line = 'run_until finished: ' + ('' if self.last_run_started else 'run not started: ') + message
        if end is not None and end.end_state not in message and (self.last_run_started or faulted):
            line += f'; {end.end_state}'
        # A clean interrupt (Ctrl-C, stop()) is not an error; a fault or a failure is.
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
