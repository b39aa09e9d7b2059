"""Direct receive for the lockstep hot path, and the one-graph-per-domain check.

An executor's ``spin_once`` costs more than a lockstep sample, so the lockstep subscriptions
sit in a :class:`DirectCallbackGroup` no executor takes from, and :class:`DirectReceiver`
waits on them with one persistent rcl wait set. :func:`graph_conflict` finds a second graph
in the domain (docs/architecture.md "Time and lockstep").
"""
from __future__ import annotations

from contextlib import ExitStack

from rclpy.callback_groups import CallbackGroup
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy

from drive_common.parameters import ParameterError


class DirectCallbackGroup(CallbackGroup):
    """Entities no executor runs (only a :class:`DirectReceiver` takes their messages)."""

    def can_execute(self, entity) -> bool:
        return False

    def beginning_execution(self, entity) -> bool:
        return False

    def ending_execution(self, entity) -> None:
        pass


class DirectReceiver:
    """Wait on subscriptions (in a :class:`DirectCallbackGroup`) and dispatch what arrives.

    One thread only calls :meth:`poll`; join it before the node is destroyed.
    """

    def __init__(self, context, subscriptions, with_info: bool = False,
                 with_publisher: bool = False) -> None:
        """with_info: call ``callback(msg, message_info)`` (timestamps); with_publisher:
        ``callback(data, publisher_gid)`` (raw subscriptions only, drive_common.peer_binding);
        else ``callback(msg)``."""
        self._subscriptions = list(subscriptions)
        self._with_info = with_info
        self._takes = None
        if with_publisher:
            from drive_common.peer_binding import IdentifiedTake
            self._takes = {sub: IdentifiedTake(sub) for sub in self._subscriptions}
        self._wait_set = _rclpy.WaitSet(len(self._subscriptions), 0, 0, 0, 0, 0, context.handle)

    def poll(self, timeout: float) -> int:
        """Dispatch every message; if none had arrived, wait up to timeout s and dispatch what
        arrives; count them (a take without the wait set is cheaper than a wait)."""
        dispatched = self._dispatch(self._subscriptions)
        if dispatched or timeout <= 0.0:
            return dispatched
        wait_set = self._wait_set
        with ExitStack() as held:
            # Hold the handles while rcl waits on them: a destroy meanwhile is deferred.
            for sub in self._subscriptions:
                held.enter_context(sub.handle)
            wait_set.clear_entities()
            for sub in self._subscriptions:
                wait_set.add_subscription(sub.handle)
            wait_set.wait(int(timeout * 1e9))
        ready = wait_set.get_ready_entities('subscription')
        return self._dispatch([sub for sub in self._subscriptions if sub.handle.pointer in ready])

    def _dispatch(self, subscriptions) -> int:
        """Take and hand over every message waiting on subscriptions; count them."""
        dispatched = 0
        for sub in subscriptions:
            if self._takes is not None:
                take = self._takes[sub]
                while (taken := take()) is not None:
                    sub.callback(*taken)
                    dispatched += 1
                continue
            while True:
                with sub.handle:
                    taken = sub.handle.take_message(sub.msg_type, sub.raw)
                if taken is None:
                    break
                if self._with_info:
                    sub.callback(taken[0], taken[1])
                else:
                    sub.callback(taken[0])
                dispatched += 1
        return dispatched


def unmatched_topics(node, publishers) -> list[str]:
    """The topics of the publishers not yet matched with every subscriber the graph lists."""
    return [pub.topic_name for pub in publishers
            if pub.get_subscription_count() < node.count_subscribers(pub.topic_name)]


def readers_matched(node, publishers) -> bool:
    """Whether each publisher is matched with every subscriber its topic has in the graph."""
    return not unmatched_topics(node, publishers)


class GraphConflict(ParameterError):
    """A second graph shares this node's domain; the node refuses to run (exit code 2)."""


def listed_nodes(node) -> list[tuple[str, str]]:
    """(name, namespace) of every node in the graph, without rmw's stale entries of departed
    ones: an entry without enclave counts only as the one node of its name with endpoints."""
    entries = node.get_node_names_and_namespaces_with_enclaves()
    names = [(name, namespace) for name, namespace, _ in entries]
    return [(name, namespace) for name, namespace, enclave in entries
            if enclave or (names.count((name, namespace)) == 1
                           and _has_endpoints(node, name, namespace))]


def _has_endpoints(node, name: str, namespace: str) -> bool:
    try:
        return bool(node.get_publisher_names_and_types_by_node(name, namespace)
                    or node.get_subscriber_names_and_types_by_node(name, namespace))
    except _rclpy.NodeNameNonExistentError:       # it left meanwhile
        return False


def graph_conflict(node, sole_publisher_of=()) -> str | None:
    """Why node must not run in its domain (a second graph is there), or None.

    sole_publisher_of: topics this node publishes that no other node may.
    """
    domain = node.context.get_domain_id()
    me = (node.get_name(), node.get_namespace())
    namesakes = listed_nodes(node).count(me)
    if namesakes > 1:
        where = me[1].rstrip('/') + '/' + me[0]
        return (f'{node.get_name()}: {namesakes} nodes named {where} in ROS domain {domain}: '
                'refusing to mix two graphs (stop the other one or set another ROS_DOMAIN_ID)')
    for topic in sole_publisher_of:
        count = node.count_publishers(topic)
        if count > 1:
            return (f'{node.get_name()}: {count} publishers of {topic} in ROS domain {domain}: '
                    'refusing to mix two graphs (stop the other one or set another ROS_DOMAIN_ID)')
    return None
