"""The ``plant`` node: lockstep time master over the ROS-agnostic PlantCore.

A thin node over :mod:`.lockstep_loop` (stepping thread), :mod:`.run_action` (plant/run,
run_until), :mod:`.peer_watch` (peers), :mod:`.parameter_merging` (parameters, motor files) and
:mod:`.faults_reporting` (faults, diagnostics). It publishes ground truth and /clock, serves
plant/reset_protection and stops cleanly (:meth:`PlantNode.stop`, Ctrl-C at any moment).
"""
from __future__ import annotations

import contextlib
import threading
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.duration import Duration
from rclpy.node import Node
from rosgraph_msgs.msg import Clock

from bldc_plant_sim.core.faults import FaultKind, RunEnd
from bldc_plant_sim.core.lockstep import ControllerKind, LockstepSchedule
from bldc_plant_sim.core.plant import PlantCore
from bldc_plant_sim.faults_reporting import LOCKSTEP_DIAGNOSTIC_NAME, FaultReporter, diagnostic_array
from bldc_plant_sim.lockstep_loop import LockstepLoop
from bldc_plant_sim.parameter_merging import ParameterMerging
from bldc_plant_sim.parameters import PLANT_SCHEMA, effective_params
from bldc_plant_sim.peer_watch import PeerWatch
from bldc_plant_sim.run_action import RunAction
from drive_common import topics
from drive_common.conversions import ReusedMessage, time_msg
from drive_common.node_main import run_node
from drive_common.parameters import ParameterError
from drive_common.ros_parameters import SchemaParameters
from drive_common.telemetry import nanoseconds
from drive_common.telemetry_blocks import BlockStream
from dtc_msgs.msg import PlantState, PlantStateBlock
from dtc_msgs.srv import ResetProtection

STOP_WAIT = 10.0                # s stop() waits for a run to end
FIRST_CLOCK_ACK_WAIT = 3.0      # s the first /clock waits for its readers' acknowledgements


class PlantNode(LockstepLoop, RunAction, PeerWatch, ParameterMerging, Node):
    """Lockstep plant: see the module docstring."""

    def __init__(self, **kwargs) -> None:
        super().__init__('plant', **kwargs)
        self._running = False
        self._busy = threading.Lock()        # held by the one run (goal or run_until) at a time
        self._stopping = threading.Event()   # set by stop(): the run ends at the next tick
        self._conflict: str | None = None    # a second graph in the domain: refuse to run
        self._refused = False
        self._graph_settled = False          # discovery waited for before the first run
        self._ready: set[ControllerKind] = set()   # controllers that answered since they last failed
        self._startup_pending: set[ControllerKind] = set()
        self._faulted: dict[ControllerKind, str | None] = {kind: None for kind in ControllerKind}
        self._silent: set[ControllerKind] = set()  # faulted by a timeout: FAULTED_GLANCE per sample
        self._fault_shown: dict[ControllerKind, bool] = {}   # its last fault was shown
        self.last_run_end: RunEnd | None = None    # how the last run ended (Run.Result fields)
        self.last_run_started = False              # whether sim time moved in it
        self._faults: list[str] = []
        self._last_sources: dict[ControllerKind, str] = {}   # the command publishers last seen
        self._pending: dict[str, Any] | None = None
        self._lock = threading.Lock()
        explicit = {n for n in PLANT_SCHEMA.names() if n in self._parameter_overrides}
        try:
            # declared with the motor file's values in: start-up publishes no parameter change
            self.parameters = SchemaParameters(
                self, PLANT_SCHEMA, on_change=self._on_parameters, is_running=lambda: self._running,
                sim_time=lambda: self.core.time,
                start_values=lambda values: effective_params(values, explicit=explicit))
            params = dict(self.parameters.values)
            self.core = PlantCore(params)
        except (ValueError, OSError) as exc:
            raise ParameterError(str(exc)) from exc   # run_node says 'cannot start'
        self.schedule = LockstepSchedule.from_params(params, self.core.base_tick)
        self.parameters.add_pre_set(self._with_motor_file_values)   # a later motor.file change
        self._open_lockstep()                # measurements out, commands in (stepping thread)
        # Ground truth: every sample in blocks (bags), a decimated live topic (people).
        self._state_pub = self.create_publisher(PlantState, topics.PLANT_STATE, topics.LIVE_QOS)
        self._block_pub = self.create_publisher(PlantStateBlock, topics.PLANT_STATE_BLOCK,
                                                topics.BLOCK_QOS)
        self._clock_pub = self.create_publisher(Clock, topics.CLOCK, topics.LIVE_QOS)
        self._clock_acked = False
        self._telemetry = BlockStream(PlantStateBlock, self._block_pub.publish,
                                      self.parameters['telemetry.block_size'],
                                      self.parameters['telemetry.live_period'])
        self._pipelined = False              # for the run under way (lockstep_loop.py)
        self._state_msg = ReusedMessage(PlantState)
        self._state_lock = threading.RLock()
        self._diag_pub = self.create_publisher(DiagnosticArray, topics.DIAGNOSTICS, 10)
        self.faults = FaultReporter(self, lambda: self.core, self._diag_pub.publish,
                                    lambda kind: self._sources(ControllerKind.GATE)
                                    if kind == FaultKind.SHOOT_THROUGH else '')
        self._serve_runs()
        self.create_service(ResetProtection, topics.RESET_PROTECTION_SERVICE, self._reset,
                            callback_group=ReentrantCallbackGroup())
        self._state_sent_step = -1   # step of the last plant/state sent (never twice)
        self._watch_graph()

    def stop(self) -> None:
        """End a run at its next tick and wait for it (before the node is destroyed)."""
        self._stopping.set()
        if self._busy.acquire(timeout=STOP_WAIT):
            self._busy.release()
        with contextlib.suppress(Exception):   # the context may already be shut down
            self._telemetry.flush()

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

    def _clock_due(self) -> bool:
        """Whether /clock goes out at this step (every clock_ticks steps)."""
        clock_ticks = self.schedule.clock_ticks
        return clock_ticks == 0 or self.core.step % clock_ticks == 0

    def _first_clock_due(self) -> bool:
        """Whether this step's state sends the first /clock (which waits for its readers)."""
        return not self._clock_acked and self._clock_due()

    def _publish_clock(self) -> None:
        """/clock at t_k every clock_ticks steps (clock_period, default 1 ms of sim time)."""
        if self._clock_due():
            self._clock_pub.publish(Clock(clock=time_msg(self.core.time)))
            if not self._clock_acked:
                # Once: every /clock reader (a recorder) matched from its own side, or it
                # would miss the first samples.
                self._clock_acked = True
                if not self._clock_pub.wait_for_all_acked(Duration(seconds=FIRST_CLOCK_ACK_WAIT)):
                    self.get_logger().warning(
                        f'a /clock reader did not acknowledge the first /clock within '
                        f'{FIRST_CLOCK_ACK_WAIT:g} s: it may miss the first samples')

    def _diagnose(self, level: bytes, message: str, values: dict[str, str]) -> None:
        """A 'plant: lockstep' status on /diagnostics at the current sim time."""
        self._diag_pub.publish(diagnostic_array(LOCKSTEP_DIAGNOSTIC_NAME, level, message, values,
                                                self.core.time))

    def _reset(self, request, response):
        ok, message = self.core.reset_protection()
        response.success, response.message = ok, message
        self.get_logger().info(f'plant/reset_protection at t = {self.core.time:.6f} s: {message}')
        if not self._running:                # else the stepping thread reports it after its tick
            self.faults.flush()              # the safe-state exit, if the reset ended one
        # The reset's extra sample of this step goes out on the live topic only.
        self._telemetry.flush()          # sim time holds: the partial block goes out
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
