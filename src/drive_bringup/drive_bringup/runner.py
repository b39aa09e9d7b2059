"""Launch-free scenario runner: the drive graph as separate processes.

Starts the scenario's nodes (its own ``nodes.controller`` under its node name) and the recorder
as ``ros2 run <pkg> <exe> --ros-args -p ...`` would, then drives the plant's ``plant/run``
action from event to event, so each event's parameter change lands at its exact sim time (the
plant holds time between goals). Shows progress, reports a crashed node with the end of its
output, and always shuts every process down, also on Ctrl-C or SIGTERM. ``pause_at`` holds the
plant at given sim times until a ``~/resume`` (std_srvs/Trigger) call.
"""
from __future__ import annotations

import os
import signal
import sys
import time
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Callable

import rclpy
from rclpy.action import ActionClient
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient

from drive_bringup.scenario import Scenario, ScenarioError
from drive_common import topics
from drive_common.domain_guard import RUNNER_NODE, DomainBusy, refuse_if_busy
from drive_common.namespaces import namespace_arguments, namespace_remappings, normalized
from drive_common.processes import NodeProcess, executable_path, graph_lock, isolated_env
from drive_common.run_goal import run_goal_result, send_run_goal
from drive_common.waiting import WaitTimeout, wait_until
from drive_common.recorder_matching import RecordersMatched
from dtc_msgs.action import Run

NODE_PROGRAMS = {
    'plant': ('bldc_plant_sim', 'plant'),
    'dtc_controller': ('dtc_controller', 'dtc_controller'),
    'pfc_controller': ('pfc_controller', 'pfc_controller'),
}


def scenario_programs(sc: Scenario) -> list[tuple[str, str, str, str | None]]:
    """(key, package, executable, node name or None) of each node of the scenario, in start order."""
    own = sc.controller
    return [(key, own.package, own.executable, own.node_name) if key == 'controller'
            else (key, *NODE_PROGRAMS[key], None) for key in sc.nodes]


def check_programs(sc: Scenario, record: bool = True, live: bool = False) -> None:
    """ScenarioError naming the first program of the run that is not built (before anything starts)."""
    wanted = [(key, package, executable) for key, package, executable, _ in scenario_programs(sc)]
    wanted += [('recorder', 'drive_logger', 'recorder')] if record else []
    wanted += [('live_view', 'drive_logger', 'live_view')] if live else []
    for key, package, executable in wanted:
        try:
            executable_path(package, executable)
        except FileNotFoundError as exc:
            where = f'nodes.{key}' if key in sc.nodes else key
            raise ScenarioError(f'{sc.path}: {where}: cannot run {package} {executable}: {exc}') from None


RESUME_LINGER = 2.0   # s of wall time the resume service stays up after the resume (see _pause)
# Every sample in blocks, no subscriber on a per-sample lockstep publish
# (docs/architecture.md "Telemetry: blocks and live topics").
DEFAULT_RECORD_TOPICS = [topics.PLANT_STATE_BLOCK, topics.DTC_STATUS_BLOCK, topics.CLOCK,
                         topics.DIAGNOSTICS,
                         topics.PARAMETER_EVENTS]   # the events' changes, for compare_replay
PFC_RECORD_TOPICS = [topics.PFC_STATUS_BLOCK]
LOCKSTEP_RECORD_TOPICS = [topics.DRIVE_MEASUREMENT, topics.GATE_COMMAND]   # record.lockstep
PFC_LOCKSTEP_RECORD_TOPICS = [topics.PFC_MEASUREMENT, topics.DUTY_COMMAND]


class RunFailed(RuntimeError):
    """The run could not complete: a node crashed, refused a parameter or timed out."""


@dataclass
class RunResult:
    scenario: str
    bag: Path | None
    final_time: float
    final_step: int
    wall_time: float
    samples_per_second: float
    log_dir: Path
    messages: list[str] = field(default_factory=list)
    end_state: str = 'ended normally'     # the plant's words (Run.Result end_state) for the run
    fault_kinds: tuple = ()               # fault kind labels recorded during the run


def _absolute_topic(name: str) -> str:
    return name if name.startswith('/') else '/' + name


def record_topics(scenario: Scenario) -> list[str]:
    """record.topics, else the default blocks; record.lockstep adds the raw lockstep topics."""
    pfc = 'pfc_controller' in scenario.nodes
    names = list(scenario.record_topics) or DEFAULT_RECORD_TOPICS + (PFC_RECORD_TOPICS if pfc else [])
    if scenario.record_lockstep:
        names += LOCKSTEP_RECORD_TOPICS + (PFC_LOCKSTEP_RECORD_TOPICS if pfc else [])
    return list(dict.fromkeys(_absolute_topic(t) for t in names))


class GraphRunner:
    """Runs one scenario through the ROS graph; see the module docstring."""

    def __init__(self, scenario: Scenario, out_dir: Path, *, domain_id: int | None = None,
                 record: bool | None = None, progress: Callable[[str], None] = partial(print, flush=True),
                 step_timeout: float = 60.0, live: bool = False, namespace: str = '',
                 pause_at: tuple[float, ...] = ()) -> None:
        self.scenario = scenario
        self.out_dir = Path(out_dir)
        self.domain_id = domain_id
        self.record = scenario.record if record is None else record
        self.progress = progress      # default: seen at once even through a pipe (tee, a script)
        self.step_timeout = step_timeout
        self.live = live      # also start drive_logger live_view (Foxglove, ws://localhost:8765)
        self.namespace = normalized(namespace)   # '/NAME': the drive's nodes run in it
        self.pause_at = tuple(sorted(pause_at))  # s of sim time: hold there until ~/resume
        self._lingering: Callable[[], None] | None = None   # retires the last hold's resume service
        self.processes: dict[str, NodeProcess] = {}
        self._crashed = False
        self._sim_time = 0.0      # s: the plant's last reported sim time (goal feedback, result)
        self.log_dir = self.out_dir / 'logs'

    # --- processes ------------------------------------------------------------
    def _placement(self, key: str) -> dict:
        """Where the program of key runs: NodeProcess's env (and wrapper prefix)."""
        return {'env': dict(os.environ) if self.domain_id is None else isolated_env(self.domain_id)}

    def _start(self, key: str, package: str, executable: str, parameters: dict,
               node_name: str | None = None) -> NodeProcess:
        process = NodeProcess(package, executable, parameters=parameters, log_dir=self.log_dir,
                              node_name=node_name, remappings=namespace_remappings(self.namespace),
                              **self._placement(key))
        self.processes[key] = process
        return process

    def _recorded(self, names: list[str]) -> list[str]:
        """Absolute topic names in the drive's namespace (what the recorder subscribes to)."""
        return [self.namespace + name for name in names]

    def _check_alive(self) -> None:
        for key, process in self.processes.items():
            if not process.alive():
                self._crashed = True
                tail = '\n'.join(process.output().splitlines()[-15:])
                code = process.process.returncode
                how = f'was killed by {signal.Signals(-code).name}' if code < 0 else f'exited with code {code}'
                raise RunFailed(f'node {key} {how}; the plant had reached t = {self._sim_time:.6f} s:\n{tail}')

    def _stop_all(self) -> None:
        """Recorder first: sim time is held, so the producers are idle but still
        alive to deliver what the recorder has not taken yet (their writer
        history); the recorder drains it, finalizes the bag, then the nodes go."""
        recorder = self.processes.get('recorder')
        plant = self.processes.get('plant')
        if self._crashed and recorder is not None and plant is not None and plant.alive():
            # A controller died mid-run: let the plant time out on it and report the
            # safe state (/diagnostics, plant/state) so the bag shows what happened.
            time.sleep(self.scenario.node_parameters['plant']['command_timeout'] + 0.5)
        if recorder is not None:
            code = recorder.stop(timeout=60.0)
            if code not in (0, None):
                self.progress(f'warning: recorder exited with {code}:\n{recorder.output()[-8000:]}')
        for key, process in self.processes.items():
            if key != 'recorder':
                process.stop()

    # --- ROS client side ----------------------------------------------------------
    def _spin_while_waiting(self, executor, predicate, timeout: float, what: str,
                            raise_timeout: bool = True):
        """Spin executor until predicate holds; RunFailed if a node dies or (unless
        raise_timeout is False: the falsy value is returned) timeout s pass."""
        def ready():
            self._check_alive()
            return predicate()
        try:
            return wait_until(ready, timeout, 0.05, what, raise_timeout=raise_timeout,
                              pause=lambda s: executor.spin_once(timeout_sec=s))
        except WaitTimeout as exc:
            raise RunFailed(str(exc)) from exc

    def run(self) -> RunResult:
        if self.domain_id is not None:          # a domain reserved for this run alone
            return self._run()
        # A shared domain: one runner per domain and namespace on this machine (a file lock,
        # whatever discovery shows yet), then the look for any other drive graph (_run).
        with graph_lock(int(os.environ.get('ROS_DOMAIN_ID') or 0), self.namespace):
            return self._run()

    def _run(self) -> RunResult:
        bag_dir = self.out_dir / 'bag'
        sc = self.scenario
        context = rclpy.Context()
        try:
            rclpy.init(context=context, domain_id=self.domain_id)
            node = rclpy.create_node(RUNNER_NODE, context=context,
                                     cli_args=namespace_arguments(self.namespace))
            if self.domain_id is None:
                # A shared domain: refuse before starting anything if a drive graph runs there.
                # Ctrl-C shuts the context down: the look ends at once, nothing is started.
                refuse_if_busy(node, 'run_scenario', stop=lambda: not rclpy.ok(context=context))
                if not rclpy.ok(context=context):
                    raise KeyboardInterrupt
            self.out_dir.mkdir(parents=True, exist_ok=True)     # after every refusal: none leaves a directory
            if self.record:
                self._start('recorder', 'drive_logger', 'recorder',
                            {'output': str(bag_dir), 'topics': [
                                t.lstrip('/') if self.namespace else t    # resolved in its namespace
                                for t in record_topics(sc)],
                             'viewer_topics': sc.record_viewer_period is not None,
                             'viewer_period': sc.record_viewer_period or 0.0})
            if self.live:
                self._start('live_view', 'drive_logger', 'live_view', {})
                self.progress(f'[{sc.name}] live view: Foxglove app -> open connection -> ws://localhost:8765')
            plant_params = dict(sc.overrides['plant'], run_until=0.0,
                                pfc_enabled='pfc_controller' in sc.nodes)
            for key, package, executable, node_name in scenario_programs(sc):
                self._start(key, package, executable,
                            plant_params if key == 'plant' else dict(sc.overrides[key]),
                            node_name=node_name)
            executor = SingleThreadedExecutor(context=context)
            executor.add_node(node)
            return self._drive(node, executor, bag_dir)
        finally:
            self._stop_all()
            rclpy.try_shutdown(context=context)

    def _wait_ready(self, node, executor, action) -> None:
        deadline = time.monotonic() + 60.0
        self._spin_while_waiting(executor, action.server_is_ready, 60.0, 'the plant action server')
        if self.record:
            from drive_logger.readiness import wait_for_recorder
            try:
                wait_for_recorder(node, self._recorded(record_topics(self.scenario)),
                                  timeout=max(1.0, deadline - time.monotonic()))
            except TimeoutError as exc:
                raise RunFailed(str(exc)) from exc
            self._wait_publishers_matched(node, executor, deadline)

    def _wait_publishers_matched(self, node, executor, deadline: float) -> None:
        """Wait until this runner is matched with every node's streamed publishers.

        Whether the recorder's subscriptions are matched with publishers that
        appeared after it is not visible from outside; the runner, started
        after the recorder, matching them too is the proxy (plus a short
        settle), so the first samples are not lost to discovery.
        """
        from drive_logger.graph_topics import GRAPH_TOPIC_TYPES, is_paced, known_type
        from drive_logger.ros_types import message_class
        pfc = 'pfc_controller' in self.scenario.nodes
        streamed = {_absolute_topic(n) for n, type_name in GRAPH_TOPIC_TYPES.items()   # the dtc_msgs topics, /clock
                    if is_paced(type_name) and (pfc or not n.startswith('pfc/'))}
        wanted = [t for t in record_topics(self.scenario) if t in streamed and known_type(t)]
        if self.scenario.controller is not None:
            # Your own controller may publish no status (a core returning None): its status
            # topics are waited for only if it publishes them once its commands are visible.
            optional = {_absolute_topic(n) for n in (topics.DTC_STATUS, topics.DTC_STATUS_BLOCK)}
            gate = self.namespace + _absolute_topic(topics.GATE_COMMAND)
            self._spin_while_waiting(executor, lambda: node.count_publishers(gate) >= 1,
                                     max(0.0, deadline - time.monotonic()), f'a publisher of {gate}')
            wanted = [t for t in wanted
                      if t not in optional or node.count_publishers(self.namespace + t) >= 1]
        probes = [node.create_subscription(message_class(known_type(t)), self.namespace + t,
                                           lambda _msg: None, topics.STREAM_QOS, raw=True) for t in wanted]
        try:
            self._spin_while_waiting(
                executor, lambda: all(p.get_publisher_count() >= 1 for p in probes),
                max(0.0, deadline - time.monotonic()), f'publishers matched on {wanted}')
        finally:
            for probe in probes:
                node.destroy_subscription(probe)
        # The recorder's own subscriptions matched with every publisher of them
        # (drive_common.recorder_matching: a volatile subscriber matched late misses samples).
        names = self._recorded(wanted)
        matched = RecordersMatched(node, names, required=[topics.RECORDER_MATCHED_SERVICE])
        try:
            self._spin_while_waiting(executor, matched, max(0.0, deadline - time.monotonic()),
                                     f'the recorder matched with the publishers of {names}')
        finally:
            matched.destroy()

    def _set_parameters(self, node, executor, target: str, values: dict) -> None:
        client = self._param_clients[target]
        future = client.set_parameters([Parameter(k, value=v) for k, v in values.items()])
        self._spin_while_waiting(executor, future.done, 30.0, f'{target} set_parameters')
        response = future.result()
        for (name, _), result in zip(values.items(), response.results):
            if not result.successful:
                raise RunFailed(f'{target} refused {name}: {result.reason}')

    def _drive(self, node, executor, bag_dir: Path) -> RunResult:
        sc = self.scenario
        self._action = ActionClient(node, Run, topics.RUN_ACTION)
        self._param_clients = {    # by node name, in the namespace
            k: AsyncParameterClient(node, sc.controller.node_name if k == 'controller' else k)
            for k in sc.nodes}
        block_ends = self._watch_status_blocks(node) if self.record else {}
        self._wait_ready(node, executor, self._action)
        self._spin_while_waiting(
            executor, lambda: all(c.services_are_ready() for c in self._param_clients.values()),
            30.0, 'the parameter services of ' + ', '.join(self._param_clients))
        self.progress(f'[{sc.name}] graph up: {", ".join(sc.nodes)}'
                      + (f' + recorder -> {bag_dir}' if self.record else ''))
        started = time.monotonic()
        self._end_state, self._fault_kinds = 'ended normally', ()
        final_step, final_time = 0, 0.0
        held = 0.0      # s of wall time spent waiting for partial blocks and paused at holds
        pauses = [(t, 1, None) for t in self.pause_at]    # at equal times: events, then the pause
        for time_s, _, event in sorted([(e.time, 0, e) for e in sc.events] + pauses,
                                       key=lambda point: point[:2]):
            if time_s > final_time:
                final_step, final_time = self._run_goal(executor, time_s, started)
                held += self._wait_status_blocks(executor, block_ends, final_step)
            if event is None:
                held += self._pause(node, executor, final_time)
                continue
            self._set_parameters(node, executor, event.node, event.parameters)
            self.progress(f'[{sc.name}] t = {event.time:.6f} s: {event.node} '
                          + ', '.join(f'{k} = {v}' for k, v in event.parameters.items()))
        if sc.duration > final_time:
            final_step, final_time = self._run_goal(executor, sc.duration, started)
        wall = time.monotonic() - started - held
        self._wait_status_blocks(executor, block_ends, final_step)
        self.progress(f'[{sc.name}] done: {final_time:.4f} s sim in {wall:.1f} s wall '
                      f'({final_step / wall:.0f} samples/s)')
        if self._fault_kinds:
            self.progress(f'[{sc.name}] {self._end_state}')
        return RunResult(sc.name, bag_dir if self.record else None, final_time, final_step, wall,
                         final_step / wall if wall > 0 else 0.0, self.log_dir,
                         end_state=self._end_state, fault_kinds=self._fault_kinds)

    def _pause(self, node, executor, sim_time: float) -> float:
        """Hold the plant at sim_time until a ~/resume call (a node that dies meanwhile fails
        the run; Ctrl-C stops it); the wall time paused."""
        from std_srvs.srv import Trigger
        begun = time.monotonic()
        released = []

        def resume(_request, response):      # (a repeated call, its reply lost, is answered alike)
            released.append(True)
            response.success, response.message = True, f'resumed at t = {sim_time:.6f} s'
            return response
        # The service exists while the plant is held (a client waiting for it waits for the
        # pause) and RESUME_LINGER s after: a reply sent before the caller's reader matched
        # the brand-new service is lost, and the caller's repeated call is still answered.
        if self._lingering is not None:
            self._lingering()           # the last hold's service, before this one's
        service = node.create_service(Trigger, '~/resume', resume)
        self.progress(f'[{self.scenario.name}] paused at t = {sim_time:.6f} s: resume with '
                      f'ros2 service call {service.service_name} std_srvs/srv/Trigger')
        try:
            self._spin_while_waiting(executor, lambda: released, float('inf'), 'a resume call')
        except BaseException:
            node.destroy_service(service)
            raise

        def retire():
            self._lingering = None
            node.destroy_timer(timer)
            node.destroy_service(service)
        timer = node.create_timer(RESUME_LINGER, retire)
        self._lingering = retire
        return time.monotonic() - begun

    @staticmethod
    def _follow_blocks(node, block_type, topic: str) -> list[int]:
        """[last step of the blocks seen on topic] (-1: none yet), kept up to date."""
        end = [-1]

        def on_block(block):
            end[0] = max(end[0], block.first_step + (block.count - 1) * block.step_stride)
        node.create_subscription(block_type, topic, on_block, topics.BLOCK_QOS)
        return end

    def _watch_status_blocks(self, node) -> dict[str, list[int]]:
        """Follow the controllers' recorded status blocks: key -> :meth:`_follow_blocks`."""
        from dtc_msgs.msg import DtcStatusBlock, PfcStatusBlock
        watched = {'dtc_controller': (DtcStatusBlock, topics.DTC_STATUS_BLOCK),
                   'pfc_controller': (PfcStatusBlock, topics.PFC_STATUS_BLOCK)}
        return {key: self._follow_blocks(node, block_type, topic)
                for key, (block_type, topic) in watched.items()
                if key in self.scenario.nodes and _absolute_topic(topic) in record_topics(self.scenario)}

    def _wait_status_blocks(self, executor, ends: dict[str, list[int]], final_step: int) -> float:
        """Wait at a hold until each controller's partial block is out (it flushes after the
        sample marked ``hold_after``); the wall time waited. So the recorder, stopped after the
        last hold, has every sample."""
        begun = time.monotonic()
        schedule = self._schedule()
        ticks = {'dtc_controller': schedule.dtc_ticks, 'pfc_controller': schedule.pfc_ticks}
        for key, end in ends.items():
            if ticks[key] and final_step > 0:
                last = (final_step - 1) // ticks[key] * ticks[key]   # last sample answered
                self._spin_while_waiting(executor, lambda: end[0] >= last, 30.0,
                                         f'the last {key} status block (step {last})')
        return time.monotonic() - begun

    def _schedule(self):
        """The plant's lockstep schedule (:class:`bldc_plant_sim.core.lockstep.LockstepSchedule`)."""
        from bldc_plant_sim.core.lockstep import LockstepSchedule
        plant = dict(self.scenario.node_parameters['plant'],
                     pfc_enabled='pfc_controller' in self.scenario.nodes)
        return LockstepSchedule.from_params(plant, plant['base_tick'])

    def _run_goal(self, executor, target: float, started: float) -> tuple[int, float]:
        """Advance the plant to target (s); (final step, final time) or RunFailed."""
        last = [0.0]

        def feedback(msg) -> None:
            fb = msg.feedback
            self._sim_time = fb.sim_time
            now = time.monotonic()
            if now - last[0] >= 1.0:
                last[0] = now
                wall = now - started
                self.progress(f'[{self.scenario.name}] sim {fb.sim_time:.4f} s / '
                              f'{self.scenario.duration:.4f} s, wall {wall:.1f} s, '
                              f'rate {fb.real_time_factor:.3f}x real time')

        def wait(done, seconds: float):
            return self._spin_while_waiting(executor, done, seconds, 'the plant', raise_timeout=False)

        try:
            handle = send_run_goal(self._action, target, feedback=feedback, wait=wait)
        except TimeoutError as exc:
            raise RunFailed(str(exc)) from exc
        if not handle.accepted:
            raise RunFailed(f'plant rejected the Run goal to {target} s')
        result = run_goal_result(handle, wait=wait)
        self._sim_time = result.final_time
        if (result.fault_count and result.message.startswith('reached t =')
                and ' with faults: ' not in result.message):
            # The target was reached in a fault state of the simulated drive (a protection,
            # a shoot-through): the run goes on (a scenario may expect it); run_scenario
            # judges the end state against expect_faults. A controller that failed the
            # lockstep ('with faults': late, invalid, lost) fails the run below.
            if not self._fault_kinds:
                self._end_state = result.end_state
            self._fault_kinds = tuple(dict.fromkeys(self._fault_kinds + tuple(result.fault_kinds)))
        elif not result.success:
            raise RunFailed(f'plant stopped at t = {result.final_time:.6f} s: {result.message}')
        return result.final_step, result.final_time


def main_guard(fn: Callable[[], int]) -> int:
    """Run fn; a refused domain (2) or a RunFailed (1) ends with a one-line message. Signals:
    run_scenario's main turns SIGINT/SIGTERM into KeyboardInterrupt from its start (exit 130)."""
    try:
        return fn()
    except DomainBusy as exc:
        print(f'[run_scenario] error: {exc}', file=sys.stderr)
        return 2
    except RunFailed as exc:
        print(f'run failed: {exc}', file=sys.stderr)
        return 1
