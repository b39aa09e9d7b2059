"""One drive graph per DDS domain (and namespace): look before starting one.

``run_scenario`` refuses (exit 2) when the settled graph already holds a drive graph: a node
with an endpoint on a lockstep topic, or another scenario runner (docs/architecture.md "Time
and lockstep").
"""
from __future__ import annotations

import time
from typing import Callable

from drive_common import topics
from drive_common.lockstep_io import listed_nodes
from drive_common.namespaces import full_name

SETTLE = 0.5               # s without a change in the graph: discovery is done
DISCOVERY_TIMEOUT = 5.0    # s at most
LOOK_AT_LEAST = 2.0        # s a look before starting a graph lasts at least
POLL = 0.05                # s between looks
RUNNER_NODE = 'scenario_runner'
DRIVE_TOPICS = (topics.DRIVE_MEASUREMENT, topics.GATE_COMMAND, topics.PFC_MEASUREMENT,
                topics.DUTY_COMMAND, topics.RUN_ACTION + '/_action/status')


class DomainBusy(Exception):
    """A drive graph already runs in the domain (and namespace): refuse to start another."""


def _graph(node) -> tuple:
    """What discovery has found so far: nodes and topics with their endpoint counts."""
    names = tuple(sorted(node.get_node_names_and_namespaces()))
    endpoints = tuple(sorted((t, node.count_publishers(t), node.count_subscribers(t))
                             for t, _ in node.get_topic_names_and_types()))
    return names, endpoints


def wait_for_stable_graph(node, settle: float = SETTLE, timeout: float = DISCOVERY_TIMEOUT,
                          stop: Callable[[], bool] = lambda: False, least: float = 0.0) -> bool:
    """Wait until the node's view of the graph has not changed for settle s and least s have
    passed (or timeout s); False if stop() returned True meanwhile."""
    start = changed = time.monotonic()
    seen = _graph(node)
    while ((time.monotonic() - changed < settle or time.monotonic() - start < least)
           and time.monotonic() - start < timeout):
        if stop():
            return False
        time.sleep(POLL)
        now = _graph(node)
        if now != seen:
            seen, changed = now, time.monotonic()
    return True


def drive_graph_nodes(node) -> list[str]:
    """Full names of the drive graph's nodes in node's domain and namespace (node excluded)."""
    found = set()
    me = (node.get_name(), node.get_namespace())
    for topic in DRIVE_TOPICS:
        resolved = node.resolve_topic_name(topic.lstrip('/'))
        for info in (*node.get_publishers_info_by_topic(resolved),
                     *node.get_subscriptions_info_by_topic(resolved)):
            if (info.node_name, info.node_namespace) != me:
                found.add(full_name(info.node_name, info.node_namespace))
    runners = [(n, ns) for n, ns in listed_nodes(node)
               if n == RUNNER_NODE and ns == node.get_namespace()]
    if len(runners) > (me in runners):         # another runner, whatever this node's name
        found.add(full_name(*runners[0]))
    return sorted(found)


def refuse_if_busy(node, what: str, stop: Callable[[], bool] = lambda: False) -> None:
    """Raise DomainBusy (one line) if a drive graph already runs where node is; stop as in
    :func:`wait_for_stable_graph` (stopped early: no look, nothing raised)."""
    if not wait_for_stable_graph(node, stop=stop, least=LOOK_AT_LEAST):
        return
    found = drive_graph_nodes(node)
    if found:
        where = f'ROS domain {node.context.get_domain_id()}'
        if node.get_namespace() != '/':
            where += f', namespace {node.get_namespace()}'
        raise DomainBusy(f'{what}: {where} already runs a drive graph (nodes: {", ".join(found)}): '
                         'refusing to start a second one (stop it, or choose another --domain-id)')
