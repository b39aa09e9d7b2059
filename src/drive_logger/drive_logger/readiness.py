"""How a scenario runner knows the recorder is ready: its subscriptions are on the graph.

:func:`wait_for_recorder` polls the graph until the recorder has a subscription on each topic.
A subscription is not yet matched with a publisher: before a run, also ask the recorder's
``recorder/matched_publishers`` service (dtc_msgs/srv/MatchedPublishers), as ``run_scenario`` does.
"""
from __future__ import annotations

from typing import Iterable

from drive_common.waiting import WaitTimeout, wait_until
from drive_logger import graph_topics


def wait_for_recorder(node, topics: Iterable[str] = graph_topics.DEFAULT_TOPICS,
                      recorder_name: str = 'recorder', timeout: float = 10.0) -> None:
    """Block until the recorder subscribes to every topic (names without ':type'); TimeoutError otherwise."""
    names = [graph_topics.parse_topic_spec(t)[0] for t in topics]

    def missing() -> list[str]:
        return [t for t in names if not any(info.node_name == recorder_name for info in
                                            node.get_subscriptions_info_by_topic(node.resolve_topic_name(t)))]
    try:
        wait_until(lambda: not missing(), timeout, 0.02)
    except WaitTimeout:
        raise TimeoutError(f'recorder {recorder_name!r} not subscribed to {missing()} after {timeout} s') from None
