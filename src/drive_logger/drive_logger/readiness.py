"""How a scenario runner knows the recorder is ready: its subscriptions are on the graph.

:func:`wait_for_recorder` polls the graph until the recorder has a subscription on each topic.
A subscription is not yet matched with a publisher: before a run, also ask the recorder's
``recorder/matched_publishers`` service (dtc_msgs/srv/MatchedPublishers), as ``run_scenario`` does.
"""
from __future__ import annotations

from typing import Iterable

from drive_common.waiting import WaitTimeout, wait_until
from drive_logger import graph_topics


def recorder_subscribed(node, topic: str, recorder_name: str = 'recorder') -> bool:
    """True if a node named recorder_name subscribes to topic (as seen from node)."""
    name = node.resolve_topic_name(topic)
    return any(info.node_name == recorder_name for info in node.get_subscriptions_info_by_topic(name))


def wait_for_recorder(node, topics: Iterable[str] = graph_topics.DEFAULT_TOPICS,
                      recorder_name: str = 'recorder', timeout: float = 10.0) -> None:
    """Block until the recorder subscribes to every topic (names without ':type'); TimeoutError otherwise."""
    names = [graph_topics.parse_topic_spec(t)[0] for t in topics]
    try:
        wait_until(lambda: all(recorder_subscribed(node, t, recorder_name) for t in names),
                   timeout, 0.02)
    except WaitTimeout:
        missing = [t for t in names if not recorder_subscribed(node, t, recorder_name)]
        raise TimeoutError(f'recorder {recorder_name!r} not subscribed to {missing} after {timeout} s') from None
