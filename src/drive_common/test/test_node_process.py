"""NodeProcess keeps a node's output for the caller, leaves no temporary folder behind, and
never leaves an orphan node when its starter dies."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from drive_common.processes import STACK_DUMP_MARK, NodeProcess, isolated_env, reserve_domain
from drive_common.starter import proc_stat
from drive_common.waiting import wait_until


def test_a_stopped_node_keeps_its_output_and_removes_its_temporary_log_folder():
    node = NodeProcess('none', 'echo_node', argv=[sys.executable, '-c', 'print("said this")'])
    folder = node.log_path.parent
    assert node.process.wait(timeout=60) == 0
    assert node.stop() == 0
    assert not folder.exists()
    assert 'said this' in node.output()
    assert node.stop() == 0 and 'said this' in node.output()     # a second stop changes nothing


def test_a_given_log_folder_is_kept(tmp_path):
    with NodeProcess('none', 'echo_node', argv=[sys.executable, '-c', 'print("kept")'],
                     log_dir=tmp_path) as node:
        node.process.wait(timeout=60)
    assert (tmp_path / 'echo_node.log').read_text().strip() == 'kept'
    assert node.output().strip() == 'kept'


# It takes SIGINT as a drive node does (run_node installs its handlers): a plain `python -c`
# keeps an ignored SIGINT inherited from a suite started in the background of a script, and
# stop() then escalates and asks it for its stacks.
SLEEPER = ('import faulthandler, signal, time\n'
           'signal.signal(signal.SIGINT, signal.default_int_handler)\n'
           'faulthandler.register(signal.SIGUSR1, all_threads=True)\n'
           'print("up", flush=True)\n'
           'def stuck_here():\n'
           '    time.sleep(600)\n'
           'stuck_here()\n')


def test_a_running_node_is_asked_for_the_stacks_of_its_threads():
    with NodeProcess('none', 'sleeper', argv=[sys.executable, '-c', SLEEPER]) as node:
        deadline = time.monotonic() + 60
        while 'up' not in node.output() and time.monotonic() < deadline:
            time.sleep(0.05)
        assert node.dump_stacks(wait=30.0)
        assert STACK_DUMP_MARK in node.output() and 'stuck_here' in node.output()
    assert not node.dump_stacks()          # a stopped node is not asked


def test_a_failed_test_shows_the_stacks_of_the_nodes_it_started(tmp_path):
    (tmp_path / 'test_stuck.py').write_text(
        'import sys\n'
        f'SLEEPER = {SLEEPER!r}\n'
        'def test_waits_on_a_stuck_node(start_node):\n'
        "    node = start_node('none', 'sleeper', argv=[sys.executable, '-c', SLEEPER])\n"
        "    while 'up' not in node.output():\n"
        '        pass\n'
        "    assert False, 'the node never answered'\n"
        'def test_passes(start_node):\n'
        "    node = start_node('none', 'sleeper', argv=[sys.executable, '-c', SLEEPER])\n"
        "    while 'up' not in node.output():\n"
        '        pass\n')
    done = subprocess.run([sys.executable, '-m', 'pytest', '-q', '-p', 'no:cacheprovider',
                           '-p', 'drive_testing.pytest_fixtures', '-rA', str(tmp_path)],
                          capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert '1 failed, 1 passed' in done.stdout, done.stdout[-3000:]
    failed, passed = done.stdout.split('= PASSES =')
    assert STACK_DUMP_MARK in failed and 'in stuck_here' in failed   # the failed test's node
    assert 'up' in passed and STACK_DUMP_MARK not in passed          # a passing test's: not asked


PROBE = ('import rclpy\n'
         'from drive_common.node_main import run_node\n'
         'def build():\n'
         "    node = rclpy.create_node('starter_watch_probe')\n"
         "    print('probe node up', flush=True)\n"
         '    return node\n'
         'code = run_node(build, args=[])\n'
         "print('probe exit', code, flush=True)\n"
         'raise SystemExit(code)\n')
STARTER = ('import sys, time\n'
           'from drive_common.processes import NodeProcess\n'
           f'PROBE = {PROBE!r}\n'
           "node = NodeProcess('none', 'probe', argv=[sys.executable, '-c', PROBE], log_dir=sys.argv[1])\n"
           "print(node.pid, flush=True)\n"
           'time.sleep(600)\n')


def _ended(pid: int) -> bool:
    """Gone, or a zombie waiting for its new parent to reap it."""
    fields = proc_stat(pid)
    return fields is None or fields[0] == 'Z'


@pytest.mark.ros
def test_a_node_stops_by_itself_when_the_process_that_started_it_is_killed(tmp_path):
    with reserve_domain() as domain_id:
        starter = subprocess.Popen([sys.executable, '-c', STARTER, str(tmp_path)],
                                   env=isolated_env(domain_id), stdout=subprocess.PIPE, text=True)
        pid = int(starter.stdout.readline())
        log = tmp_path / 'probe.log'
        try:
            wait_until(lambda: 'probe node up' in log.read_text(), 120.0, 0.05)
            starter.kill()                                  # no chance to stop its node
            starter.wait(timeout=60)
            wait_until(lambda: _ended(pid), 120.0, 0.05)
            text = log.read_text()
            assert f'the process that started it (pid {starter.pid}) has ended: stopping' in text
            assert 'probe exit 0' in text, text              # stopped as on Ctrl-C
        finally:
            starter.kill()
            if not _ended(pid):
                os.kill(pid, signal.SIGKILL)


def test_a_starter_whose_pid_now_belongs_to_another_process_counts_as_ended(monkeypatch, capsys):
    from drive_common.starter import STARTER_PID_VARIABLE, start_time, watch_starter
    other = subprocess.Popen(['sleep', '60'])
    try:
        started = int(start_time(other.pid))
        monkeypatch.setenv(STARTER_PID_VARIABLE, f'{other.pid}:{started - 1}')   # an earlier owner of the pid
        assert watch_starter() is False
        assert f'(pid {other.pid}) has already ended: not starting' in capsys.readouterr().err
    finally:
        other.kill()
        other.wait()
    monkeypatch.setenv(STARTER_PID_VARIABLE, f'{other.pid}:{started}')   # the very process, now gone
    assert watch_starter() is False
