"""Fault injection matrix: every fault kind into real runs, and what each run said about it.

Each case runs ``run_scenario`` (graph in a private domain, or ``--headless``) on a short
scenario and injects one fault at INJECT_AT, where a graph run is held (``--pause-at``) so
the injection never races the simulation: a signal to a node, bytes or messages from an
outsider on a lockstep topic, a bad parameter, or a scenario event that makes the drive fault.
Per case: reported (log line, /diagnostics status and run result, as :data:`EXPECTED`
requires), silent (none of those), crashed (traceback, hang, unexplained exit code) and
changed (an outsider's run whose recorded drive data differ from a clean run's).
"""
from __future__ import annotations

import os
import random
import re
import signal
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import yaml
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.duration import Duration
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from std_srvs.srv import Trigger

from drive_bringup.scenario import find_scenario
from drive_common import topics
from drive_common.domain_guard import RUNNER_NODE
from drive_common.lockstep_io import readers_matched
from drive_common.processes import NodeProcess
from drive_common.starter import proc_stat, starter_env
from drive_common.waiting import wait_until
from drive_logger.bag_reader import BagReadError
from drive_logger.ros_types import message_class
from drive_testing.block_bags import recorded_samples
from drive_testing.harness import (RosSession, call_until_answered, isolated_env, processes_with_env,
                                   reserve_domain)

SCENARIO = 'two_phase_six_switch_torque_step'
DURATION = 0.3             # s of sim time per run (long enough in wall time for an injection at INJECT_AT)
INJECT_AT = 0.01           # s of sim time at which a fault is injected
COMMAND_TIMEOUT = 1.0      # s of wall time (plant), so a late controller faults quickly
SECOND_NODE_LOOK = 20.0    # s of wall time a late node gets to find the paused graph and refuse
RUN_TIMEOUT = 240.0        # s of wall time for one run_scenario
LOG_LINE = re.compile(r'^\[(WARN|ERROR)\]', re.M)

# What a case must report: 'fault' -> log + diagnostics + a failed result naming it (headless:
# the result); 'outsider' -> log + diagnostics, the run ends normally with unchanged data;
# 'refused' -> the parameter service refuses with a reason, the run is unchanged;
# 'node lost' -> the runner's result names the node that died.
EXPECTED = ('fault', 'outsider', 'refused', 'node lost')


class Injection:
    """A graph run held at INJECT_AT, and what an injector may use on it."""

    def __init__(self, domain_id: int, runner: subprocess.Popen, node) -> None:
        """runner: the case's run_scenario (its nodes are its children); node: an rclpy node
        in the run's domain, spun by its session."""
        self.domain_id, self.runner, self.node = domain_id, runner, node
        self.runner_pid = runner.pid
        self.diagnostics: list = []
        self.notes: list = []
        self._reader = node.create_subscription(DiagnosticArray, topics.DIAGNOSTICS,
                                                lambda m: self.diagnostics.extend(m.status), 100)
        self._resume_client = node.create_client(Trigger, f'/{RUNNER_NODE}/resume')  # up while held
        self._resumed = False

    def _ended(self) -> bool:
        return self.runner.poll() is not None

    def wait_paused(self) -> None:
        """Until the run is held at INJECT_AT (or has ended)."""
        wait_until(lambda: self._resume_client.service_is_ready() or self._ended(), RUN_TIMEOUT,
                   what=f'the run held at {INJECT_AT} s')

    def _reporters_matched(self) -> bool:
        """This reader is matched with every /diagnostics publisher, the plant's and the
        controller's (the publisher of its commands) among them."""
        reporters = {i.node_name for i in self.node.get_publishers_info_by_topic(topics.DIAGNOSTICS)}
        controllers = {i.node_name for i in self.node.get_publishers_info_by_topic(topics.GATE_COMMAND)
                       } - {self.node.get_name()}     # (this injector's own outsider publisher)
        return (bool(controllers) and {'plant', *controllers} <= reporters
                and self._reader.get_publisher_count() >= len(reporters))

    def resume(self) -> None:
        """Once this reader has every /diagnostics publisher (none of the fault's reports is
        lost to discovery), let the held run go on; at most once, never after its end."""
        if self._resumed:
            return
        self._resumed = True
        self.wait_paused()
        wait_until(lambda: self._ended() or self._reporters_matched(), 60.0,
                   what="the plant's and the controller's /diagnostics publishers")
        # The run has gone on once the call is answered or the service (up while held) is gone.
        call_until_answered(self._resume_client, Trigger.Request(), RUN_TIMEOUT,
                            stop=lambda: self._ended() or not self._resume_client.service_is_ready(),
                            what='the resumed run')

    def pid(self, executable: str) -> int:
        """The pid of the run's node process started as ``executable`` (a child of this case's
        runner: a process of an earlier run in the domain, still exiting, is not taken)."""
        for pid in processes_with_env(f'ROS_DOMAIN_ID={self.domain_id}'):
            try:
                cmdline = Path(f'/proc/{pid}/cmdline').read_bytes().split(b'\0')
            except OSError:
                continue
            fields = proc_stat(pid)
            if fields is None or int(fields[1]) != self.runner_pid:
                continue
            if b'--ros-args' in cmdline and any(part.endswith(executable.encode()) for part in cmdline):
                return pid
        raise LookupError(f'no {executable} process in domain {self.domain_id}')

    def publish(self, msg_type, topic: str, messages, period: float = 0.002) -> None:
        """Publish messages (objects or raw CDR bytes) on topic as an outsider, made while the run
        is held (the graph's peers are bound) and matched with every reader of the graph: the
        first half while the run is paused, the rest once it runs again."""
        self.wait_paused()
        pub = self.node.create_publisher(msg_type, topic, topics.LOCKSTEP_QOS)
        # every reader the graph has (the plant's and the recorder's): matched with one only,
        # the other would miss what is sent before its side matched
        wait_until(lambda: pub.get_subscription_count() >= 1 and readers_matched(self.node, [pub]),
                   30.0, what=f'the readers of {topic}')
        half = len(messages) // 2
        for index, msg in enumerate(messages):
            if index == half:
                self.resume()
            pub.publish(msg)
            time.sleep(period)    # an outsider's pace, not a synchronisation
        pub.wait_for_all_acked(Duration(seconds=10.0))   # delivered, not dropped with the publisher
        self.node.destroy_publisher(pub)


@dataclass
class Case:
    name: str
    expect: str                                       # one of EXPECTED
    inject: Callable[[Injection], None] | None = None   # graph injector (None: by scenario)
    headless: bool = False
    events: list = field(default_factory=list)         # extra scenario events
    controller: dict | None = None                     # scenario controller entry instead of DTC
    exit_codes: tuple = (0,)
    kind: str = ''                                     # what the run's verdict line must name
    duration: float = DURATION                         # s of sim time of the run


@dataclass
class Outcome:
    case: str
    where: str
    expect: str
    log: bool = False
    diagnostics: bool = False
    result: bool = False
    crashed: str = ''
    changed: bool | None = None
    detail: str = ''

    @property
    def reported(self) -> bool:
        if self.expect == 'fault':
            return self.result and (self.where == 'headless' or (self.log and self.diagnostics))
        if self.expect == 'outsider':
            return self.log and self.diagnostics and self.result
        return self.result

    @property
    def silent(self) -> bool:
        return not (self.log or self.diagnostics or self.result)


def _signal(executable: str, sig: int, resume_after: float | None = None):
    """The signal right after the paused run goes on: the node is lost mid-run, not at a hold."""
    def inject(ctx: Injection) -> None:
        ctx.wait_paused()
        pid = ctx.pid(executable)
        ctx.resume()
        os.kill(pid, sig)
        if resume_after is not None:
            time.sleep(resume_after)    # the controller stays stopped past command_timeout
            os.kill(pid, signal.SIGCONT)
    return inject


def _outsider(msg_type_name: str, topic: str, make: Callable[[type, random.Random], list]):
    """Publish make(message class, a seeded rng) on topic as an outsider: messages or raw CDR bytes."""
    def inject(ctx: Injection) -> None:
        cls = message_class(msg_type_name)
        ctx.publish(cls, topic, make(cls, random.Random(7)))
    return inject


def _truncated(cls: type, rng: random.Random) -> list[bytes]:
    return [b'\x00\x01\x00\x00' + bytes(rng.randrange(256) for _ in range(rng.randrange(0, 12)))
            for _ in range(20)]


def _random(cls: type, rng: random.Random) -> list[bytes]:
    return [bytes(rng.randrange(256) for _ in range(rng.randrange(0, 120))) for _ in range(20)]


def _valid(cls: type, rng: random.Random) -> list:
    return [cls(step=step) for step in range(0, 2000, 100)]


def _parameter(node: str, name: str, value):
    """A set_parameters call on node while the run is held; noted as refused (with a reason) or taken."""
    def inject(ctx: Injection) -> None:
        ctx.wait_paused()
        client = AsyncParameterClient(ctx.node, node)
        client.wait_for_services(timeout_sec=30.0)
        future = client.set_parameters([Parameter(name, value=value)])
        wait_until(future.done, 30.0, what=f'set {name} on {node}')
        result = future.result().results[0]
        ctx.notes.append(('refused' if not result.successful and result.reason else 'taken',
                          f'{name}={value!r}: {result.reason}'))
    return inject


def _second_node(package: str, executable: str, node_name: str):
    """A late node started while the run is paused; the run goes on once the node has refused
    (exited) or, if it stays, after SECOND_NODE_LOOK s, so it can intrude while the run runs."""
    def inject(ctx: Injection) -> None:
        ctx.wait_paused()
        process = NodeProcess(package, executable, env=isolated_env(ctx.domain_id),
                              node_name=node_name)
        ctx.notes.append(('process', process))
        wait_until(lambda: not process.alive(), SECOND_NODE_LOOK, 0.05, raise_timeout=False)
    return inject


LOCKSTEP = (('dtc_msgs/msg/GateCommand', '/drive/gate_command'),
            ('dtc_msgs/msg/DriveMeasurement', '/drive/measurement'))
SHOOT_THROUGH_CONTROLLER = {'package': 'drive_testing', 'executable': 'fixed_responder',
                            'core': 'drive_testing.fixed_responder:FixedResponderCore',
                            'parameters': {'switch_on': [0.0] * 6}}   # all off until the event


def cases() -> list[Case]:
    """The matrix: every fault kind over the graph, the scenario-driven ones headless too."""
    out = [
        Case('controller SIGKILL', 'fault', _signal('dtc_controller', signal.SIGKILL), exit_codes=(1, 3),
             kind='dtc_controller'),
        Case('controller SIGTERM', 'fault', _signal('dtc_controller', signal.SIGTERM), exit_codes=(1, 3),
             kind='dtc_controller'),
        Case('controller SIGSTOP (late commands)', 'fault',
             _signal('dtc_controller', signal.SIGSTOP, resume_after=2.5 * COMMAND_TIMEOUT),
             exit_codes=(1, 3), kind='no gate command'),
        Case('recorder SIGKILL', 'node lost', _signal('recorder', signal.SIGKILL), exit_codes=(1,),
             kind='recorder'),
    ]
    for type_name, topic in LOCKSTEP:
        short = type_name.rsplit('/', 1)[1]
        out += [Case(f'truncated {short} bytes', 'outsider', _outsider(type_name, topic, _truncated)),
                Case(f'random bytes on {topic}', 'outsider', _outsider(type_name, topic, _random)),
                Case(f'intruding {short} messages', 'outsider', _outsider(type_name, topic, _valid))]
    out += [
        # A late node that finds the running graph refuses to join it (exit 2, one line) or, if
        # it gets to send, is ignored and reported by the graph: a run long enough for either.
        Case('second fake controller', 'outsider',
             _second_node('drive_testing', 'fixed_responder', 'intruding_controller'), duration=0.3),
        Case('second plant, late', 'outsider', _second_node('bldc_plant_sim', 'plant', 'late_plant'),
             duration=0.3),
        Case('out-of-range plant parameter', 'refused', _parameter('/plant', 'load.torque', 1e9)),
        Case('wrong-type plant parameter', 'refused', _parameter('/plant', 'load.torque', 'high')),
        Case('out-of-range controller parameter', 'refused',
             _parameter('/dtc_controller', 'torque_band', -1.0)),
    ]
    trip = {'time': INJECT_AT, 'node': 'plant', 'parameters': {'sensors.current_offset': [100.0, 0.0, 0.0]}}
    shoot = {'time': INJECT_AT, 'node': 'controller', 'parameters': {'switch_on': [1.0] * 6}}
    for headless in (False, True):
        out += [Case('protection trip (sensor offset)', 'fault', headless=headless, events=[trip],
                     exit_codes=(3,), kind='motor_over_current'),
                Case('shoot-through', 'fault', headless=headless, events=[shoot],
                     controller=SHOOT_THROUGH_CONTROLLER, exit_codes=(3,), kind='shoot_through')]
    return out


def _scenario_file(case: Case, directory: Path) -> Path:
    tree = yaml.safe_load(find_scenario(SCENARIO).read_text())
    tree['duration'] = case.duration
    tree['events'] = [e for e in tree.get('events') or [] if e['time'] < case.duration] + case.events
    tree['events'].sort(key=lambda e: e['time'])
    tree['checks'], tree['figures'] = [], []
    if case.controller is not None:
        tree['nodes'].pop('dtc_controller', None)
        tree['events'] = [e for e in tree['events'] if e['node'] != 'dtc_controller']
        tree['nodes']['controller'] = dict(case.controller)
        tree['metrics'] = {}
    tree['nodes']['plant'].setdefault('parameters', {})['command_timeout'] = COMMAND_TIMEOUT
    path = directory / f'{SCENARIO}_{re.sub(r"[^a-z0-9]+", "_", case.name.lower())}.yaml'
    path.write_text(yaml.safe_dump(tree))
    return path


def run_case(case: Case, directory: Path, reference: dict | None = None) -> Outcome:
    """Run one case; its Outcome (``reference``: a clean run's block data, for outsiders)."""
    where = 'headless' if case.headless else 'graph'
    outcome = Outcome(case.name, where, case.expect)
    scenario = _scenario_file(case, directory)
    out = directory / f'out_{where}_{scenario.stem}'
    command = [sys.executable, '-m', 'drive_bringup.runner_cli', str(scenario), '--out', str(out),
               '--overwrite'] + (['--headless'] if case.headless else ['--pause-at', str(INJECT_AT)])
    if case.headless:
        code, text = _run(command, None)
        outcome.detail = _last_line(text)
        outcome.result = _names_fault(code, text, case)
        outcome.crashed = _crash(code, text, case)
        return outcome
    with reserve_domain() as domain_id:
        code, text, ctx = _run_graph(command + ['--domain-id', str(domain_id)], case, domain_id)
    logs = '\n'.join(p.read_text(errors='replace') for p in (out / 'logs').glob('*.log'))
    outcome.log = bool(LOG_LINE.search(logs))
    outcome.diagnostics = any(_level(s) >= 1 for s in ctx.diagnostics)
    refused = _refused_itself(ctx)
    if refused:            # a late node that found the running graph refused to join it
        outcome.log = outcome.diagnostics = True
        outcome.detail = refused
    outcome.crashed = next((f'injection failed: {why}' for kind, why in ctx.notes
                            if kind == 'injection failed'), '') or _crash(code, text + logs, case)
    outcome.result = (any(kind == 'refused' for kind, _ in ctx.notes) if case.expect == 'refused'
                      else _names_fault(code, text, case))
    if case.expect in ('outsider', 'refused') and reference is not None and (out / 'bag').is_dir():
        try:
            outcome.changed = recorded_samples(out / 'bag') != reference
        except BagReadError as exc:     # a run that failed: its unfinished bag is the detail
            outcome.crashed = outcome.crashed or f'bag unreadable: {exc}'
    outcome.detail = outcome.detail or _last_line(text)
    return outcome


def _last_line(text: str) -> str:
    return text.strip().splitlines()[-1] if text.strip() else ''


def _refused_itself(ctx: Injection) -> str:
    """The one-line refusal of an intruding node that exited 2 on finding the graph, or ''."""
    for kind, process in ctx.notes:
        if kind == 'process' and process.process.poll() == 2:
            lines = [ln for ln in process.output().splitlines() if 'refusing' in ln]
            if lines:
                return lines[-1]
    return ''


def _level(status) -> int:
    """A DiagnosticStatus level as a number (rclpy gives a byte: b'\\x02')."""
    level = status.level
    return level[0] if isinstance(level, (bytes, bytearray)) else int(level)


def _names_fault(code: int, text: str, case: Case) -> bool:
    """Whether the run's exit code and the last line in which run_scenario says how it ended
    (a failed run, a fault state, the end state) say what the case did."""
    if case.expect == 'outsider':
        return code == 0
    ends = [line for line in text.splitlines()
            if line.startswith(('run failed:', 'run_scenario:', '[run_scenario]'))]
    return code in case.exit_codes and code != 0 and case.kind in (ends[-1] if ends else '')


def _crash(code: int | None, text: str, case: Case) -> str:
    if code is None:
        return 'hung'
    if 'Traceback (most recent call last)' in text:
        return 'traceback'
    if code not in case.exit_codes:
        return f'exit code {code}'
    return ''


def _run(command, env) -> tuple[int | None, str]:
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=RUN_TIMEOUT, env=env)
    except subprocess.TimeoutExpired as exc:
        return None, (exc.stdout or '') + (exc.stderr or '')
    return done.returncode, done.stdout + done.stderr


def _run_graph(command, case: Case, domain_id: int):
    """Start run_scenario in domain_id, inject while it is held, wait for its end."""
    log = tempfile.TemporaryFile(mode='w+')
    runner = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, text=True,
                              env=starter_env(isolated_env(domain_id)), start_new_session=True)
    session = RosSession(domain_id)
    ctx = Injection(domain_id, runner, session.node('fault_injector'))
    try:
        try:
            if case.inject is not None:
                case.inject(ctx)
            ctx.resume()      # a case whose injector did not let the run go on
        except Exception as exc:  # noqa: BLE001 - the run ended before the fault could go in
            ctx.notes.append(('injection failed', f'{type(exc).__name__}: {exc}'))
            if runner.poll() is None:
                os.killpg(runner.pid, signal.SIGINT)     # paused for ever otherwise
        try:
            code = runner.wait(timeout=RUN_TIMEOUT)
        except subprocess.TimeoutExpired:
            os.killpg(runner.pid, signal.SIGKILL)
            runner.wait()
            code = None
        deadline = time.monotonic() + 2.0     # diagnostics published at the very end
        while time.monotonic() < deadline and not ctx.diagnostics and case.expect != 'refused':
            time.sleep(0.05)
    finally:
        for kind, item in ctx.notes:
            if kind == 'process':
                item.stop()
        session.close()
    log.seek(0)
    return code, log.read(), ctx


def clean_reference(directory: Path, duration: float = DURATION) -> dict[str, list[bytes]]:
    """The block data of the scenario run without a fault (what outsiders must not change)."""
    clean = Case(f'clean {duration:g} s', 'outsider', duration=duration)
    scenario = _scenario_file(clean, directory)
    out = directory / f'clean_{duration:g}'
    with reserve_domain() as domain_id:
        code, text = _run([sys.executable, '-m', 'drive_bringup.runner_cli', str(scenario), '--out', str(out),
                           '--overwrite', '--domain-id', str(domain_id)], isolated_env(domain_id))
    if code != 0:
        raise RuntimeError(f'the clean run failed (exit {code}): {text[-2000:]}')
    return recorded_samples(out / 'bag')


def run_matrix(directory: Path, select: Callable[[Case], bool] = lambda case: True,
               progress: Callable[[Outcome], None] = lambda outcome: None,
               workers: int = 1) -> list[Outcome]:
    """Run the selected cases (with a clean reference run per duration); their outcomes, in
    the matrix's order. workers: cases run at once, each in its own ROS domain (most of a
    case's wall time is process start-up and discovery, so two overlap well on two cores)."""
    selected = [case for case in cases() if select(case)]
    durations = sorted({c.duration for c in selected if c.expect in ('outsider', 'refused')})
    with ThreadPoolExecutor(max_workers=max(1, workers)) as pool:
        references = dict(zip(durations, pool.map(lambda d: clean_reference(directory, d),
                                                  durations)))

        def one(case: Case) -> Outcome:
            outcome = run_case(case, directory, references.get(case.duration))
            progress(outcome)
            return outcome
        return list(pool.map(one, selected))


def table(outcomes: list[Outcome]) -> str:
    """The matrix as text: one row per case, then the totals with their goals."""
    rows = [f'{"case":42s} {"where":9s} {"expect":9s} log diag result  crashed   changed']
    for o in outcomes:
        rows.append(f'{o.case:42s} {o.where:9s} {o.expect:9s} {_mark(o.log):3s} {_mark(o.diagnostics):4s} '
                    f'{_mark(o.result):6s}  {o.crashed or "-":9s} '
                    f'{"-" if o.changed is None else "YES" if o.changed else "no"}')
    rows += [f'  {o.case} ({o.where}): {o.detail}' for o in outcomes
             if not o.reported or o.crashed or o.changed]      # the run's last line, to see why
    rows += ['', f'faults injected: {len(outcomes)}',
             f'reported (as their kind requires): {sum(o.reported for o in outcomes)}',
             f'silent: {sum(o.silent for o in outcomes)} (goal 0)',
             f'crashes: {sum(bool(o.crashed) for o in outcomes)} (goal 0)',
             f'runs an outsider changed: {sum(bool(o.changed) for o in outcomes)} (goal 0)']
    return '\n'.join(rows)


def _mark(flag: bool) -> str:
    return 'yes' if flag else 'NO'
