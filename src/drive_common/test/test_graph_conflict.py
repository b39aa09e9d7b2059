"""drive_common.lockstep_io.graph_conflict against a fake node's graph: a second node of the
same name or a second publisher of a sole-publisher topic is a conflict; the stale entry that
rmw's graph cache can keep of a departed process (no enclave) is not."""
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy

from drive_common.lockstep_io import graph_conflict, listed_nodes


class FakeGraph:
    """A node named /plant in domain 7 whose graph holds the given entries and endpoints."""

    class _Context:
        @staticmethod
        def get_domain_id():
            return 7

    context = _Context()

    def __init__(self, entries, endpoints=(), publishers=None):
        self.entries = list(entries)                 # (name, namespace, enclave)
        self.endpoints = set(endpoints)              # (name, namespace) with any endpoint
        self.publishers = publishers or {}           # topic -> count

    def get_name(self):
        return 'plant'

    def get_namespace(self):
        return '/'

    def get_node_names_and_namespaces_with_enclaves(self):
        return list(self.entries)

    def get_publisher_names_and_types_by_node(self, name, namespace):
        if not any(e[:2] == (name, namespace) for e in self.entries):
            raise _rclpy.NodeNameNonExistentError(name)
        return [('/rosout', ['rcl_interfaces/msg/Log'])] if (name, namespace) in self.endpoints else []

    def get_subscriber_names_and_types_by_node(self, name, namespace):
        return []

    def count_publishers(self, topic):
        return self.publishers.get(topic, 1)


ME = ('plant', '/', '/')


def test_a_second_node_of_the_same_name_is_a_conflict_naming_the_domain():
    reason = graph_conflict(FakeGraph([ME, ('plant', '/', '/')]))
    assert reason.startswith('plant: 2 nodes named /plant in ROS domain 7: refusing')


def test_a_departed_process_left_in_the_graph_cache_is_no_conflict():
    ghost = ('plant', '/', '')                       # no enclave and no endpoint of its own
    # Asked by name, the graph answers with the live plant's endpoints: they must not count.
    graph = FakeGraph([ME, ghost, ('fixed_responder', '/', '/')], endpoints={('plant', '/')})
    assert graph_conflict(graph) is None
    assert listed_nodes(graph) == [('plant', '/'), ('fixed_responder', '/')]


def test_a_node_without_enclave_counts_only_as_the_one_node_of_its_name_with_endpoints():
    arriving = ('recorder', '/', '')
    assert listed_nodes(FakeGraph([ME, arriving], endpoints={('recorder', '/')})) == [
        ('plant', '/'), ('recorder', '/')]
    assert listed_nodes(FakeGraph([ME, arriving])) == [('plant', '/')]


def test_a_second_publisher_of_a_sole_publisher_topic_is_a_conflict():
    graph = FakeGraph([ME], publishers={'/drive/measurement': 2})
    assert '2 publishers of /drive/measurement' in graph_conflict(graph, ['/drive/measurement'])
    assert graph_conflict(FakeGraph([ME]), ['/drive/measurement']) is None
