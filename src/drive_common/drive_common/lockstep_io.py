"""Direct receive for the lockstep hot path, and the one-graph-per-domain check.

An executor's ``spin_once`` rebuilds its wait set and task bookkeeping on
every call, which in rclpy costs more than the rest of a lockstep sample.
The lockstep subscriptions therefore live on the node itself (so ``ros2
node info`` shows them) but in a :class:`DirectCallbackGroup`, which no
executor ever waits on or takes from; :class:`DirectReceiver` waits on them
with one persistent rcl wait set and hands each message to the
subscription's callback, the way rclpy's own ``wait_for_message`` does.
Services, parameters and actions stay on the node's normal executor.

:func:`graph_conflict` finds a second graph in the node's DDS domain (a
second node of the same name, a second publisher of a topic only this node
may publish): the lockstep protocol matches commands by step only, so two
graphs in one domain would silently answer each other's samples. It counts
nodes by :func:`listed_nodes`, which leaves out the stale entries rmw's graph
cache may keep of a departed process (they would make a node refuse for good).
"""
from __future__ import annotations

from contextlib import ExitStack

from rclpy.callback_groups import CallbackGroup
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy

from drive_common.parameters import ParameterError


class DirectCallbackGroup(CallbackGroup):
    """Entities no executor runs: rclpy's executors skip a group whose ``can_execute`` is False.

    Subscriptions in this group are received only by a :class:`DirectReceiver`,
    so each message is taken by exactly one thread.
    """

    def can_execute(self, entity) -> bool:
        return False

    def beginning_execution(self, entity) -> bool:
        return False

    def ending_execution(self, entity) -> None:
        pass


class DirectReceiver:
    """Wait on subscriptions and dispatch what arrives.

    The subscriptions must be in a :class:`DirectCallbackGroup` (or on a node
    no executor spins), or an executor would take their messages too. Only
    one thread may call :meth:`poll` (the wait set is not shared), and the
    node must not be destroyed while it does (stop and join that thread first).
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
        """Dispatch every message; if none had arrived, wait up to timeout s (0: do not wait)
        and dispatch what arrives; count them.

        What has arrived is taken without the wait set (a pipelined peer's next
        message is often there already, and a wait costs more than a take).
        """
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
    """Whether each publisher is matched with every subscriber its topic has in the graph.

    Checked before a run's first sample by the plant and the controllers, so a
    reader already in the graph (a recorder, a monitor) misses no sample.
    """
    return not unmatched_topics(node, publishers)


class GraphConflict(ParameterError):
    """A second graph shares this node's domain; the node refuses to run (exit code 2)."""


def listed_nodes(node) -> list[tuple[str, str]]:
    """(name, namespace) of every node in the graph, without the stale entries of departed ones.

    rmw's graph cache (rmw_dds_common, Jazzy) can keep, for good, a node whose process
    has left (seen on a loaded machine, next to a live namesake; likely a
    ``ros_discovery_info`` update handled after the participant's removal, which
    re-creates it). Such an entry has no enclave: a node's enclave comes with its
    participant's discovery, which precedes its ``ros_discovery_info``. An entry without
    one is kept only if it is the one node of its name and the graph lists endpoints of
    that name (the graph is asked by name, so a namesake's endpoints would vouch for it).
    """
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

    sole_publisher_of: topics this node publishes that no other node may
    (the plant's measurements, a controller's commands).
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
