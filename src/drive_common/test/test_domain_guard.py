"""drive_common.domain_guard's graph settle against a fake node: it ends when stable, at timeout,
or at once when its stop predicate turns True (Ctrl-C, shutdown)."""
import pytest

from drive_common import domain_guard
from drive_common.domain_guard import DomainBusy


class ChangingGraph:
    """A fake node whose graph gains a node at every look: it never settles."""

    def __init__(self):
        self.looks = 0

    def get_node_names_and_namespaces(self):
        self.looks += 1
        return [(f'node_{i}', '/') for i in range(self.looks)]

    def get_topic_names_and_types(self):
        return []


class StillGraph(ChangingGraph):
    """A fake node whose graph never changes; drive_graph_nodes must not be reached when stopped."""

    def get_node_names_and_namespaces(self):
        self.looks += 1
        return [('plant', '/')]

    def resolve_topic_name(self, topic):
        raise AssertionError('the domain was looked at after the stop')


def flips_after(calls: int):
    """A stop predicate that returns True from its calls-th call on, counting its calls."""
    def stop():
        stop.calls += 1
        return stop.calls >= calls
    stop.calls = 0
    return stop


def test_stop_predicate_ends_an_unsettled_wait_early():
    node, stop = ChangingGraph(), flips_after(3)
    # The graph never settles: without stop this wait would last the whole (long) timeout.
    assert domain_guard.wait_for_stable_graph(node, settle=30.0, timeout=60.0, stop=stop) is False
    assert stop.calls == 3
    assert node.looks == 3           # the first look, then one per poll before the stop


def test_stable_graph_returns_true_and_polls_stop_meanwhile():
    node, stop = StillGraph(), flips_after(10 ** 9)
    assert domain_guard.wait_for_stable_graph(node, settle=0.1, timeout=60.0, stop=stop) is True
    assert stop.calls >= 1 and node.looks == stop.calls + 1


def test_timeout_ends_an_unsettled_wait_without_stop():
    node = ChangingGraph()
    assert domain_guard.wait_for_stable_graph(node, settle=30.0, timeout=0.2) is True
    assert node.looks >= 2


def test_refuse_if_busy_stopped_looks_no_further():
    domain_guard.refuse_if_busy(StillGraph(), 'test', stop=lambda: True)   # no AssertionError


class LateGraph(ChangingGraph):
    """A fake node that finds a plant only at its third look (a loaded machine's late answer)."""

    def get_node_names_and_namespaces(self):
        self.looks += 1
        return [('plant', '/')] if self.looks >= 3 else []


def test_a_look_lasts_at_least_least_seconds_so_a_late_answer_is_seen():
    node = LateGraph()
    # An empty graph is 'stable' at once (settle ~0); least keeps looking until the plant shows.
    assert domain_guard.wait_for_stable_graph(node, settle=1e-6, timeout=60.0, least=2.0) is True
    assert node.looks >= 3 and ('plant', '/') in node.get_node_names_and_namespaces()


def test_a_second_runner_on_this_machine_is_refused_at_once_by_the_graph_lock():
    """One runner per domain and namespace on a machine, whatever discovery shows yet; another
    namespace of the same domain is free, and a released lock can be taken again."""
    import os
    from drive_common.processes import graph_lock
    domain = 200 + os.getpid() % 30          # above the ids reserve_domain hands out
    with graph_lock(domain):
        with pytest.raises(DomainBusy) as refused:
            with graph_lock(domain):
                pass
        message = str(refused.value)
        assert f'ROS domain {domain} already runs a drive graph' in message
        assert f'run_scenario pid {os.getpid()}' in message and '/scenario_runner' in message
        with graph_lock(domain, '/drive2'):   # a namespaced drive beside it
            pass
    with graph_lock(domain):                   # released with its holder
        pass
