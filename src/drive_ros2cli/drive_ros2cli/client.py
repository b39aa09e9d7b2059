"""The command's own hidden ROS node (no daemon: upstream's ``--no-daemon``): discovery for
``--spin-time`` s and until the graph settles, graph queries, and calls with time-outs."""
from __future__ import annotations

import os
import time
from typing import Callable

from drive_common.namespaces import full_name
from drive_common.waiting import wait_until
from drive_ros2cli.errors import CliError

SETTLE_PERIOD = 1.0      # s the graph must stay unchanged to count as discovered
SETTLE_EXTRA = 3.0       # s spent at most after --spin-time waiting for it to settle
NAME_WAIT = 3.0          # s a named node/topic/service/action may take to appear before it is unknown
DEFAULT_TIMEOUT = 5.0    # s a remote call (service, parameter, action) may take


def add_node_arguments(parser) -> None:
    """Options upstream ros2cli gives every verb that talks to the graph."""
    parser.add_argument('--spin-time', type=float, default=0.5, metavar='SPIN_TIME',
                        help='Spin time in seconds to wait for discovery (default: %(default)s)')
    parser.add_argument('-s', '--use-sim-time', action='store_true',
                        help='Enable ROS simulation time')
    parser.add_argument('--no-daemon', action='store_true',
                        help='Do not spawn nor use an already running daemon '
                             '(there is none in the embedded set-up: always so)')


def print_names_and_types(items, count_only: bool, show_types: bool) -> int:
    """The `list` verbs' output: a count, or one name a line (with `[types]` on request)."""
    if count_only:
        print(len(items))
        return 0
    for name, types in items:
        print(f"{name} [{', '.join(types)}]" if show_types else name)
    return 0


def absolute_name(name: str) -> str:
    return name if name.startswith('/') else '/' + name


def is_hidden(name: str) -> bool:
    """ROS convention: a name with a segment starting with '_' is hidden."""
    return any(part.startswith('_') for part in name.split('/'))


def split_node_name(full_name: str) -> tuple[str, str]:
    """'/ns/name' -> ('name', '/ns')."""
    full_name = absolute_name(full_name)
    namespace, _, name = full_name.rpartition('/')
    return name, namespace or '/'


class CliNode:
    """Context manager: rclpy context + hidden node for one command."""

    def __init__(self, args=None, name: str = 'ros2cli') -> None:
        import rclpy
        from rclpy.parameter import Parameter
        self.args = args
        self.context = rclpy.Context()
        rclpy.init(context=self.context, args=[])
        overrides = []
        if args is not None and getattr(args, 'use_sim_time', False):
            overrides.append(Parameter('use_sim_time', value=True))
        self.node = rclpy.create_node(f'_{name}_{os.getpid()}', context=self.context,
                                      start_parameter_services=False,
                                      parameter_overrides=overrides)
        from rclpy.executors import SingleThreadedExecutor
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._discovered = False

    def __enter__(self) -> 'CliNode':
        return self

    def __exit__(self, *exc) -> None:
        import rclpy
        from drive_common.node_main import destroy_node_and_actions
        self.executor.shutdown(timeout_sec=1.0)
        destroy_node_and_actions(self.node)    # (action verbs add an action client)
        rclpy.try_shutdown(context=self.context)

    def _snapshot(self):
        """Nodes, topics with their endpoint counts, services: what discovery still adds to."""
        node = self.node
        topics = sorted((n, tuple(t), node.count_publishers(n), node.count_subscribers(n))
                        for n, t in node.get_topic_names_and_types())
        return (sorted(node.get_node_names_and_namespaces()), topics,
                sorted((n, tuple(t)) for n, t in node.get_service_names_and_types()))

    def discover(self) -> None:
        """Wait --spin-time s, then until the graph is unchanged for SETTLE_PERIOD s."""
        if self._discovered:
            return
        self._discovered = True
        spin_time = float(getattr(self.args, 'spin_time', 0.5) or 0.0)
        self.spin_for(spin_time)
        deadline = time.monotonic() + SETTLE_EXTRA
        last = self._snapshot()
        while time.monotonic() < deadline:
            self.spin_for(SETTLE_PERIOD)
            now = self._snapshot()
            if now == last and len(now[0]) > 1:      # settled, and someone besides us is there
                return
            last = now

    def wait_for_name(self, lookup: Callable[[], object], timeout: float = NAME_WAIT) -> object:
        """After discovery, wait up to timeout s for lookup() to find a named entity."""
        self.discover()
        return self.wait_for(lookup, timeout)

    def spin_for(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while (left := end - time.monotonic()) > 0:
            self.executor.spin_once(timeout_sec=min(left, 0.05))

    def wait_for(self, predicate: Callable[[], object], timeout: float) -> object:
        """Spin until predicate() is truthy; its value (the last, falsy one after timeout s)."""
        return wait_until(predicate, timeout, 0.05, pause=lambda t: self.executor.spin_once(timeout_sec=t),
                          raise_timeout=False)

    def call(self, future, timeout: float, what: str):
        """Result of a future, spinning; CliError naming ``what`` after timeout s."""
        self.executor.spin_until_future_complete(
            future, timeout_sec=None if timeout == float('inf') else timeout)
        if not future.done():
            future.cancel()
            raise CliError(f'{what}: no answer within {timeout:g} s')
        if future.exception() is not None:
            raise CliError(f'{what}: {future.exception()}')
        return future.result()

    def node_names(self, include_hidden: bool = False) -> list[str]:
        self.discover()
        names = {full_name(n, ns) for n, ns in self.node.get_node_names_and_namespaces()}
        return sorted(n for n in names if include_hidden or not is_hidden(n))

    def require_node(self, full_name: str, timeout: float = NAME_WAIT, include_hidden: bool = True) -> str:
        """The absolute name of a running node; CliError('Node not found') otherwise."""
        full_name = absolute_name(full_name)
        if not self.wait_for_name(lambda: full_name in self.node_names(include_hidden=include_hidden),
                                  timeout):
            raise CliError('Node not found')
        return full_name

    def topics(self, include_hidden: bool = False) -> list[tuple[str, list[str]]]:
        self.discover()
        return sorted((n, t) for n, t in self.node.get_topic_names_and_types()
                      if include_hidden or not is_hidden(n))

    def services(self, include_hidden: bool = False) -> list[tuple[str, list[str]]]:
        self.discover()
        return sorted((n, t) for n, t in self.node.get_service_names_and_types()
                      if include_hidden or not is_hidden(n))
