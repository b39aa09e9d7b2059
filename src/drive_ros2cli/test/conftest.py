"""Helpers for the ros2 command tests: run the installed `ros2` in a domain's environment."""
from __future__ import annotations

import os
import shutil
import signal
import subprocess
from dataclasses import dataclass
from pathlib import Path

import pytest

from drive_common.node_main import STACK_DUMP_SIGNAL
from drive_common.processes import STACK_DUMP_MARK
from drive_common.starter import starter_env
from drive_testing.harness import NodeProcess, isolated_env, reserve_domain, wait_until

ROS2 = shutil.which('ros2')
CALL_TIMEOUT = 120.0     # s: a hung command fails the test instead of hanging it


@dataclass
class Result:
    code: int
    out: str
    err: str


class Ros2:
    """Runs `ros2 ...` as a user would, in one private domain."""

    def __init__(self, env: dict, workdir: Path) -> None:
        assert ROS2, 'no ros2 on PATH: run scripts/setup.sh and source scripts/env.sh'
        self.env, self.workdir = env, workdir
        self.started: list[subprocess.Popen] = []

    def __call__(self, *args: str) -> Result:
        done = subprocess.run([ROS2, *args], env=self.env, capture_output=True, text=True,
                              timeout=CALL_TIMEOUT, cwd=self.workdir)
        return Result(done.returncode, done.stdout, done.stderr)

    def ok(self, *args: str) -> str:
        result = self(*args)
        assert result.code == 0, f'ros2 {" ".join(args)} -> {result.code}\n{result.out}\n{result.err}'
        return result.out

    def start(self, *args: str, name: str) -> 'Streaming':
        """A long-running `ros2 ...` whose output goes to a file."""
        log = self.workdir / f'{name}.out'
        stream = open(log, 'w')
        process = subprocess.Popen([ROS2, *args], env=starter_env(self.env), stdout=stream,
                                   stderr=subprocess.STDOUT, text=True, start_new_session=True,
                                   cwd=self.workdir)
        self.started.append(process)
        return Streaming(process, log)

    def close(self) -> None:
        for process in self.started:
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait(timeout=10)


class Streaming:
    def __init__(self, process: subprocess.Popen, log: Path) -> None:
        self.process, self.log = process, log

    def output(self) -> str:
        return self.log.read_text(errors='replace')

    def wait_for_output(self, text: str, timeout: float = 60.0) -> str:
        wait_until(lambda: text in self.output() or self.process.poll() is not None, timeout,
                   what=f'{text!r} in the output of {self.process.args}')
        assert text in self.output(), self.output()
        return self.output()

    def interrupt(self, timeout: float = 30.0) -> int:
        """Ctrl-C; the exit code. A command still running after timeout s fails the test
        with the stacks of its threads (the CLI dumps them on STACK_DUMP_SIGNAL)."""
        os.killpg(self.process.pid, signal.SIGINT)
        try:
            return self.process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.kill(self.process.pid, STACK_DUMP_SIGNAL)
            wait_until(lambda: STACK_DUMP_MARK in self.output(), 10.0, what='the stuck command\'s stacks')
            os.killpg(self.process.pid, signal.SIGKILL)
            raise AssertionError(f'{self.process.args} still running {timeout:g} s after SIGINT:\n'
                                 f'{self.output()[-6000:]}') from None


@pytest.fixture
def ros2_offline(tmp_path):
    """`ros2` for verbs that need no running node (own domain all the same)."""
    with reserve_domain() as domain:
        cli = Ros2(isolated_env(domain), tmp_path)
        try:
            yield cli
        finally:
            cli.close()


PLANT = {'motor.file': 'ozturk_bldc', 'dc_link.voltage': 10.0, 'motor.initial_speed': 20.0,
         'load.torque': 0.2, 'command_timeout': 10.0}


@pytest.fixture(scope='module')
def drive_graph(tmp_path_factory):
    """plant + fixed_responder running in a private domain; yields the `ros2` runner."""
    workdir = tmp_path_factory.mktemp('ros2cli')
    with reserve_domain() as domain:
        env = isolated_env(domain)
        nodes = [NodeProcess('drive_testing', 'fixed_responder', env=env, log_dir=workdir / 'nodes',
                             parameters={'switch_on': [1.0, 0.0, 0.0, 1.0, 0.0, 0.0]}),
                 NodeProcess('bldc_plant_sim', 'plant', env=env, log_dir=workdir / 'nodes', parameters=PLANT)]
        cli = Ros2(env, workdir)
        try:
            wait_until(lambda: not all(n.alive() for n in nodes) or (
                '/plant/run' in cli('action', 'list').out
                and '/fixed_responder/get_parameters' in cli('service', 'list').out), 90.0,
                what='plant action and fixed_responder services')
            assert all(n.alive() for n in nodes), [n.output() for n in nodes]
            yield cli
        finally:
            cli.close()
            for node in nodes:
                node.stop()
                print(f'----- {node.executable} -----\n{node.output()[-3000:]}')
