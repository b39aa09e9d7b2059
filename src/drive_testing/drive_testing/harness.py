"""Launch-free test harness: run drive nodes in tests and benchmarks without launch files.

Node processes and private DDS domains come from :mod:`drive_common.processes` (re-exported);
:class:`RosSession` is an in-process rclpy context in a domain with a background executor;
:func:`domain_context` and :func:`private_domain` give just the context; the ``wait_for_*``,
:func:`send_until_answered`, :func:`answer_of` and :func:`call_until_answered` helpers wait for graph matching
and answers as the plant does.
"""
from __future__ import annotations

import os
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator, NamedTuple

from drive_common.processes import (NodeProcess, executable_path, isolated_env, keep_reserved, reserve_domain,
                                    ros_arguments)
from drive_common.node_main import destroy_node_and_actions, node_alive, spin_in_background
from drive_common.waiting import WaitTimeout, wait_until

__all__ = ['NodeProcess', 'PrivateDomain', 'RosSession', 'WaitTimeout', 'answer_of', 'domain_context',
           'executable_path', 'isolated_env', 'private_domain', 'processes_with_env', 'reserve_domain',
           'ros_arguments', 'send_until_answered', 'wait_for_subscribers', 'wait_until']


def processes_with_env(marker: str) -> list[int]:
    """PIDs (other than this one) whose environment holds the entry marker, 'KEY=value' exactly:
    the leftovers of a runner started with it, even re-parented ones."""
    found = []
    entry = marker.encode()
    for proc in Path('/proc').iterdir():
        if proc.name.isdigit() and int(proc.name) != os.getpid():
            try:
                if entry in (proc / 'environ').read_bytes().split(b'\0'):
                    found.append(int(proc.name))
            except OSError:
                continue
    return found


@contextmanager
def domain_context(domain_id: int) -> Iterator:
    """An rclpy context initialised in domain_id, shut down on exit."""
    import rclpy
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain_id)
    try:
        yield context
    finally:
        rclpy.try_shutdown(context=context)


class PrivateDomain(NamedTuple):
    domain_id: int
    context: object               # rclpy.Context initialised in domain_id
    env: dict[str, str]           # environment for node processes in domain_id


@contextmanager
def private_domain() -> Iterator[PrivateDomain]:
    """A reserved DDS domain with an rclpy context in it and the environment for its node processes."""
    with reserve_domain() as domain, domain_context(domain) as context:
        yield PrivateDomain(domain, context, isolated_env(domain))


class RosSession:
    """An rclpy context in one domain with an executor spinning in a thread; its nodes
    (:meth:`node`, :meth:`add`) are destroyed by :meth:`close`."""

    def __init__(self, domain_id: int) -> None:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
        self.domain_id = domain_id
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=domain_id)
        # Single-threaded: rclpy's multi-threaded executor (7.1) delays callbacks by up to
        # seconds while its spinning thread holds the GIL (ros2/rclpy#1452).
        self.executor = SingleThreadedExecutor(context=self.context)
        self._nodes: list = []
        self._thread = spin_in_background(self.executor, 'ros_session')

    def node(self, name: str, **kwargs):
        """A plain rclpy node in this session."""
        from rclpy.node import Node
        return self.add(Node(name, context=self.context, **kwargs))

    def add(self, node):
        self._nodes.append(node)
        self.executor.add_node(node)
        return node

    @property
    def spinning(self) -> bool:
        """Whether the executor's thread still runs."""
        return self._thread.is_alive()

    def close(self) -> None:
        """Stop spinning, destroy the nodes and leave the domain, whatever fails on the way: a
        node left alive after its domain is released would be found by the next holder."""
        import rclpy
        stopped = False
        try:
            stopped = self.executor.shutdown(timeout_sec=10.0)
        finally:
            try:
                for node in self._nodes:
                    destroy_node_and_actions(node)
            finally:
                rclpy.try_shutdown(context=self.context)
                self._thread.join(timeout=10.0)
                if not stopped or self._thread.is_alive() or any(map(node_alive, self._nodes)):
                    # Something still holds a node, whose destruction rclpy then defers: its
                    # participant stays in the domain, which no later test may be given.
                    keep_reserved(self.domain_id)

    def __enter__(self) -> 'RosSession':
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def wait_for_subscribers(node, topic: str, count: int = 1, timeout: float = 10.0) -> None:
    wait_until(lambda: node.count_subscribers(topic) >= count, timeout,
               what=f'{count} subscriber(s) on {topic}')


def send_until_answered(publish, answered, timeout: float = 30.0, every: float = 1.0,
                        what: str = 'answer') -> None:
    """publish() then wait for answered(); re-send every ``every`` s until timeout [s], as the
    plant re-sends a sample a controller dropped before it bound to its peer."""
    deadline = time.monotonic() + timeout
    while True:
        publish()
        left = deadline - time.monotonic()
        if wait_until(answered, max(0.0, min(every, left)), what=what, raise_timeout=False):
            return
        if time.monotonic() >= deadline:
            raise WaitTimeout(f'timed out after {timeout:.1f} s waiting for {what}')


def answer_of(call: Callable, what: str = 'answer', timeout: float = 30.0, every: float = 5.0,
              stop: Callable[[], bool] = lambda: False):
    """The first result of call() (an idempotent request: its future, as a parameter client or
    ``call_async`` gives), made again every ``every`` s until one is answered (a reply sent
    before the server matched this client's reader is lost: rmw "failed to send response");
    None if stop() holds first. Needs an executor spinning the client's node elsewhere."""
    calls = []
    send_until_answered(lambda: calls.append(call()),
                        lambda: stop() or any(f.done() for f in calls), timeout, every, what)
    return next((f.result() for f in calls if f.done()), None)


def call_until_answered(client, request, timeout: float = 30.0, every: float = 2.0,
                        stop: Callable[[], bool] = lambda: False, what: str = 'answer'):
    """:func:`answer_of` a service call."""
    return answer_of(lambda: client.call_async(request), what, timeout, every, stop)

