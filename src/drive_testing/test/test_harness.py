"""The launch-free harness itself: domains, in-process nodes, process teardown."""
import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from rclpy.parameter import Parameter

from drive_common import processes, topics
from drive_testing.fixed_responder import FixedResponder
from drive_testing.harness import (NodeProcess, RosSession, isolated_env, processes_with_env, reserve_domain,
                                   ros_arguments, wait_for_subscribers)
from drive_common.waiting import wait_until


def test_reserved_domains_are_exclusive_across_processes():
    probe = ('from drive_testing.harness import reserve_domain\n'
             'import sys\n'
             'with reserve_domain() as d:\n'
             '    print(d, flush=True); sys.stdin.read()\n')   # held until this test kills it
    with reserve_domain() as mine:
        others = [subprocess.Popen([sys.executable, '-c', probe], stdin=subprocess.PIPE,
                                   stdout=subprocess.PIPE, text=True)
                  for _ in range(3)]
        try:
            ids = [int(p.stdout.readline()) for p in others]
        finally:
            for p in others:
                p.kill()
                p.wait()
    assert len({mine, *ids}) == 4, (mine, ids)


def test_ros_arguments_are_what_ros2_run_takes():
    args = ros_arguments({'a': 1.0, 'b': True, 'c': 'x y', 'd': [1.0, 2.0], 'e': 3},
                         {'from': 'to'}, node_name='n')
    assert args == ['--ros-args', '-r', '__node:=n', '-p', 'a:=1.0', '-p', 'b:=true',
                    '-p', 'c:="x y"', '-p', 'd:=[1.0, 2.0]', '-p', 'e:=3', '-r', 'from:=to']


def test_isolated_env_confines_discovery():
    env = isolated_env(42, base={'ROS_LOCALHOST_ONLY': '1', 'PATH': '/bin'})
    assert env['ROS_DOMAIN_ID'] == '42' and env['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'LOCALHOST'
    assert 'ROS_LOCALHOST_ONLY' not in env and env['PATH'] == '/bin'


@pytest.mark.ros
def test_node_in_process_with_injected_context_and_parameter_overrides(ros_session):
    """A project node built in the test's own context, its parameters overridden at birth."""
    from dtc_msgs.msg import DriveMeasurement, GateCommand
    pattern = [0.0, 1.0, 1.0, 0.0, 0.0, 0.0]
    responder = ros_session.add(FixedResponder(
        context=ros_session.context,
        parameter_overrides=[Parameter('switch_on', value=pattern)]))
    assert responder.parameters['switch_on'] == pattern
    node = ros_session.node('probe')
    replies = []
    node.create_subscription(GateCommand, topics.GATE_COMMAND, replies.append, topics.LOCKSTEP_QOS)
    pub = node.create_publisher(DriveMeasurement, topics.DRIVE_MEASUREMENT, topics.LOCKSTEP_QOS)
    wait_for_subscribers(node, topics.DRIVE_MEASUREMENT)
    wait_until(lambda: node.count_publishers(topics.GATE_COMMAND) >= 1, 10.0)
    pub.publish(DriveMeasurement(step=5))
    wait_until(lambda: replies, 10.0, what='reply')
    assert replies[0].step == 5 and [float(s) for s in replies[0].switch_on] == pattern


@pytest.mark.ros
def test_node_process_stops_and_leaves_nothing(ros_domain, tmp_path):
    marker = f'DTC_HARNESS_PROBE=stop_{os.getpid()}_{time.monotonic_ns()}'
    env = dict(isolated_env(ros_domain), DTC_HARNESS_PROBE=marker.split('=', 1)[1])
    process = NodeProcess('drive_testing', 'message_echo', env=env, log_dir=tmp_path)
    wait_until(lambda: processes_with_env(marker), 10.0, what='node started')
    assert process.alive()
    process.stop()
    assert not process.alive() and processes_with_env(marker) == []


def test_a_drive_node_that_ignores_sigint_leaves_its_stacks_in_its_output(ros_domain, tmp_path):
    """stop() asks a node still running after SIGINT where it is (faulthandler, registered by
    run_node for every drive node) before it escalates."""
    from drive_common.node_main import STACK_DUMP_SIGNAL
    node = NodeProcess('drive_testing', 'message_echo', env=isolated_env(ros_domain), log_dir=tmp_path)
    wait_until(lambda: processes.catches_signal(node.pid, STACK_DUMP_SIGNAL), 30.0,
               what='the node registered its stack dump')
    stuck = NodeProcess('stuck', 'stuck', log_dir=tmp_path, argv=[sys.executable, '-c', textwrap.dedent("""
        import faulthandler, signal, time
        faulthandler.register(signal.SIGUSR1, all_threads=True)
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)   # stopped only by SIGKILL, after its dump
        print('ready', flush=True)
        def parked_in_here():
            time.sleep(600)
        parked_in_here()
        """)])
    wait_until(lambda: 'ready' in stuck.output(), 30.0, what='the stuck process')
    stuck.stop(timeout=3.0)
    assert not stuck.alive()
    assert 'parked_in_here' in stuck.output() and 'most recent call first' in stuck.output()
    node.stop()


@pytest.mark.ros
def test_start_node_fixture_tears_down_when_the_test_fails(tmp_path):
    """A failing test that started a node leaves no process behind."""
    marker = f'DTC_HARNESS_PROBE=fail_{os.getpid()}_{time.monotonic_ns()}'
    test_file = tmp_path / 'test_failing_probe.py'
    test_file.write_text(textwrap.dedent('''
        from drive_common.waiting import wait_until
        def test_fails(start_node, ros_session):
            node = start_node('drive_testing', 'message_echo')
            probe = ros_session.node('probe')
            wait_until(lambda: probe.count_subscribers('/echo/in/DriveMeasurement') >= 1, 60.0,
                       what='message_echo up')
            assert node.alive()
            assert False, 'deliberate failure'
    '''))
    conftest = Path(__file__).resolve().parents[3] / 'conftest.py'
    (tmp_path / 'conftest.py').write_text(conftest.read_text())
    env = dict(os.environ, DTC_HARNESS_PROBE=marker.split('=', 1)[1])
    result = subprocess.run([sys.executable, '-m', 'pytest', '-q', '-p', 'no:cacheprovider',
                             str(test_file)], cwd=tmp_path, env=env, capture_output=True,
                            text=True, timeout=120)
    assert result.returncode == 1 and 'deliberate failure' in result.stdout, result.stdout
    assert processes_with_env(marker) == []


_LOCK_PROBE = textwrap.dedent('''
    import fcntl, os, sys
    from drive_common import processes
    fd = os.open(processes._LOCK_DIR / f'{sys.argv[1]}.lock', os.O_CREAT | os.O_RDWR, 0o666)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        print('free')
    except OSError:
        print('held')
''')


def _held_elsewhere(domain: int, **env) -> bool:
    """Whether another process finds the lock of domain held."""
    out = subprocess.run([sys.executable, '-c', _LOCK_PROBE, str(domain)], capture_output=True,
                         text=True, env=dict(os.environ, **env), timeout=60)
    assert out.stdout.strip() in ('held', 'free'), out.stdout + out.stderr
    return out.stdout.strip() == 'held'


def test_a_domain_held_here_is_held_for_a_run_with_another_tmpdir(tmp_path):
    """The locks are machine-wide: a program started with its own TMPDIR sees the same ones."""
    with reserve_domain() as domain:
        assert _held_elsewhere(domain, TMPDIR=str(tmp_path))


def test_a_kept_domain_stays_reserved_after_its_block():
    """A session that could not destroy its nodes keeps its domain for the process's life."""
    with reserve_domain() as released:
        pass
    assert not _held_elsewhere(released)
    with reserve_domain() as kept:
        processes.keep_reserved(kept)
    assert _held_elsewhere(kept)


def test_a_session_whose_node_outlives_close_keeps_its_domain():
    """A node in use while the session closes is destroyed later by rclpy: its participant
    stays in the domain, so the domain stays reserved."""
    with reserve_domain() as domain:
        session = RosSession(domain)
        node = session.node('in_use_at_close')
        with node.handle:                  # as a callback still running would hold it
            session.close()
    assert _held_elsewhere(domain)


def test_a_released_domain_rests_before_reuse():
    with reserve_domain() as first:
        pass
    with reserve_domain() as second:
        assert second != first        # lingering participants of `first` cannot be matched


@pytest.mark.ros
def test_a_session_spins_on_when_another_thread_destroys_an_entity_mid_wait(ros_session):
    """Destroying a publisher while the executor builds its wait set raises InvalidHandle in
    the spinning thread (rclpy); the session keeps serving its other entities."""
    from std_msgs.msg import String
    node = ros_session.node('churn')
    received = []
    node.create_subscription(String, 'kept', received.append, 10)
    talker = node.create_publisher(String, 'kept', 10)
    # Many waitables (each publisher's event handlers) widen the window in which the executor
    # has listed the churned publisher's handlers but not yet marked them in use; each creation
    # wakes the executor into that window.
    for i in range(300):
        node.create_publisher(String, f'other_{i}', 10)
    for _ in range(3000):
        node.destroy_publisher(node.create_publisher(String, 'churned', 10))
    assert ros_session.spinning
    wait_until(lambda: talker.get_subscription_count() >= 1, 30.0, what='the kept subscription')
    talker.publish(String(data='still served'))
    wait_until(lambda: received, 30.0, what='a message on the kept topic')
    assert received[0].data == 'still served'


class _StubExecutor:
    """What spin_in_background uses of an rclpy executor; spin() raises ``error``, after
    setting the guard condition to None as Executor.shutdown() does when ``shut_down``."""

    def __init__(self, error: Exception, context_ok: bool = True, shut_down: bool = False) -> None:
        self.error, self.shut_down, self._guard = error, shut_down, object()
        self.context = type('Context', (), {'ok': lambda _self: context_ok})()

    def spin(self):
        if self.shut_down:
            self._guard = None
        raise self.error

    def get_nodes(self):
        return []


def _spinner_errors(executor: _StubExecutor) -> list[type]:
    """The types of the exceptions that end spin_in_background's thread on executor."""
    import threading
    from drive_common.node_main import spin_in_background
    failures = []
    hook, threading.excepthook = threading.excepthook, lambda args: failures.append(args.exc_value)
    try:
        spin_in_background(executor).join(10.0)
    finally:
        threading.excepthook = hook
    return [type(f) for f in failures]


def test_the_spinner_ends_quietly_when_its_context_is_shut_down_mid_wait_and_only_then():
    """rclpy raises RCLError ("context is not valid") when the context is shut down while the
    executor builds its wait set: the spinning thread ends without an error then, and still
    fails loudly on any other RCLError."""
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
    error = _rclpy.RCLError('failed to initialize wait set: the given context is not valid')
    assert _spinner_errors(_StubExecutor(error, context_ok=False)) == []
    assert _spinner_errors(_StubExecutor(error, context_ok=True)) == [_rclpy.RCLError]


def test_the_spinner_ends_quietly_when_its_executor_is_shut_down_mid_wait_and_only_then():
    """Executor.shutdown() from another thread sets the executor's guard condition to None
    while the spinning thread may be building its wait set, where rclpy then raises
    AttributeError (ros2/rclpy#968): the thread ends without an error then, and fails
    loudly on an AttributeError of a live executor."""
    error = AttributeError("'NoneType' object has no attribute 'handle'")
    assert _spinner_errors(_StubExecutor(error, shut_down=True)) == []
    assert _spinner_errors(_StubExecutor(error, shut_down=False)) == [AttributeError]


def test_a_closed_session_leaves_the_graph_even_with_action_endpoints(ros_domain):
    """rclpy's destroy_node leaves action clients and servers, and each keeps its node in
    the graph while the process lives: a later holder of the domain found a test's node
    there and took it for a running drive graph (run_scenario refused to start)."""
    from rclpy.action import ActionClient, ActionServer
    from dtc_msgs.action import Run
    observer = RosSession(ros_domain)
    try:
        watcher = observer.node('graph_observer')

        def listed() -> set:
            return {name for name, _ in watcher.get_node_names_and_namespaces()}

        closing = RosSession(ros_domain)
        client_node, server_node = closing.node('leaving_client'), closing.node('leaving_server')
        ActionClient(client_node, Run, topics.RUN_ACTION)
        ActionServer(server_node, Run, 'other/run', execute_callback=lambda goal: Run.Result())
        wait_until(lambda: {'leaving_client', 'leaving_server'} <= listed(), 30.0,
                   what='both nodes in the observer graph')
        closing.close()
        wait_until(lambda: not {'leaving_client', 'leaving_server'} & listed(), 30.0,
                   what='both nodes gone from the observer graph')
    finally:
        observer.close()
