"""PeerBinding names an intruder by its own endpoint, never by a guess while the graph
still has to say whose it is (drive_common.peer_binding)."""
from __future__ import annotations

import logging

from drive_common.peer_binding import PARTICIPANT_PREFIX, UNKNOWN_NODE, PeerBinding

PROCESS = bytes([7] * PARTICIPANT_PREFIX)    # one DDS participant: the nodes of one process


class _Endpoint:
    def __init__(self, gid: bytes, node: str, namespace: str = '/') -> None:
        self.endpoint_gid, self.node_name, self.node_namespace = list(gid), node, namespace


class _Graph:
    """The graph queries PeerBinding makes, answered from what the test lists."""

    def __init__(self) -> None:
        self.publishers: dict[str, list[_Endpoint]] = {}
        self.subscriptions: dict[str, list[_Endpoint]] = {}

    def resolve_topic_name(self, topic: str) -> str:
        return topic

    def get_name(self) -> str:
        return 'plant'

    def get_namespace(self) -> str:
        return '/'

    def get_fully_qualified_name(self) -> str:
        return '/plant'

    def get_logger(self):
        return logging.getLogger('plant')

    def get_publishers_info_by_topic(self, topic: str) -> list[_Endpoint]:
        return list(self.publishers.get(topic, []))

    def get_subscriptions_info_by_topic(self, topic: str) -> list[_Endpoint]:
        return list(self.subscriptions.get(topic, []))

    def get_topic_names_and_types(self):
        return [(t, []) for t in {*self.publishers, *self.subscriptions}]


def _unnamed_intruder():
    """A plant's binding, and an intruder of the watcher's process whose name has not come."""
    graph = _Graph()
    graph.subscriptions['/diagnostics'] = [_Endpoint(PROCESS + b'\0\0\0\1', 'diagnostics_watch')]
    intruder = PROCESS + b'\0\0\0\2'           # a new node of the same process, its name to come
    graph.publishers['/drive/gate_command'] = [
        _Endpoint(intruder, UNKNOWN_NODE, '_NODE_NAMESPACE_UNKNOWN_')]
    reports = []
    binding = PeerBinding(graph, '/drive/gate_command', '/drive/measurement',
                          report=lambda message, values: reports.append(values['intruder']))
    assert binding.accepts(intruder) is False
    return graph, binding, intruder, reports


def test_an_intruder_whose_node_name_has_not_come_is_not_blamed_on_another_node_of_its_process():
    graph, binding, intruder, reports = _unnamed_intruder()
    binding.check()
    assert reports == [], 'named by a guess: the only other node of its process'
    graph.publishers['/drive/gate_command'] = [_Endpoint(intruder, 'intruder_cli')]
    binding.check()
    assert reports == ['/intruder_cli']
    binding.flush()
    assert reports == ['/intruder_cli'], 'reported once'


def test_an_intruder_still_unnamed_when_the_run_ends_is_reported_by_gid():
    _, binding, intruder, reports = _unnamed_intruder()
    binding.flush()
    assert reports == [f'an undiscovered node (publisher gid {intruder.hex()})']
