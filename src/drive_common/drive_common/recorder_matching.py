"""Whether the recorders in the graph have matched a node's publishers from their own side.

DDS discovery is one-sided for a moment: a publisher can list a subscriber as
matched before that subscriber has matched the publisher, and a volatile
subscriber that matches only after the first samples went out never gets
them. A recorder tells, on its ``~/matched_publishers`` service
(dtc_msgs/srv/MatchedPublishers), how many publishers each of its
subscriptions has matched; the plant (before its first run) and the scenario
runner ask every recorder until its answer covers every publisher.
"""
from __future__ import annotations

import time
from typing import Iterable

SERVICE_SUFFIX = '/matched_publishers'
SERVICE_TYPE = 'dtc_msgs/srv/MatchedPublishers'
RESEND_PERIOD = 1.0   # s: a request unanswered this long is sent again (a reply to a new client can be lost)


class RecordersMatched:
    """A predicate, polled: True once every recorder has matched every publisher of topics.

    A recorder counts once its service is in the graph (``required`` services
    are waited for even before); topics it does not subscribe are not asked.
    The node's executor must serve ``callback_group`` while this is polled.
    """

    def __init__(self, node, topic_names: Iterable[str], required: Iterable[str] = (),
                 callback_group=None) -> None:
        self.node = node
        self.topics = [node.resolve_topic_name(t) for t in topic_names]
        self.required = {node.resolve_service_name(s) for s in required}
        self.callback_group = callback_group
        self._clients: dict = {}
        self._pending: dict = {}       # service -> (future, topics asked, time sent)
        self._done: set[str] = set()
        self.waiting_for: list[str] = []

    def __call__(self) -> bool:
        services = self.required | {name for name, types in self.node.get_service_names_and_types()
                                    if SERVICE_TYPE in types and name.endswith(SERVICE_SUFFIX)}
        self.waiting_for = sorted(s for s in services - self._done if not self._answered(s))
        return not self.waiting_for

    def destroy(self) -> None:
        for client in self._clients.values():
            self.node.destroy_client(client)
        self._clients.clear()

    def _recorded(self, service: str) -> list[str]:
        recorder = service[:-len(SERVICE_SUFFIX)]
        return [t for t in self.topics
                if any(_full_name(i.node_namespace, i.node_name) == recorder
                       for i in self.node.get_subscriptions_info_by_topic(t))]

    def _answered(self, service: str) -> bool:
        """Whether service's recorder has matched every publisher (sends or re-sends the ask)."""
        from dtc_msgs.srv import MatchedPublishers
        future, asked, sent = self._pending.get(service, (None, [], 0.0))
        if future is not None and future.done() and future.result() is not None:
            del self._pending[service]
            counts = future.result().publishers
            if all(n >= max(1, self.node.count_publishers(t)) for t, n in zip(asked, counts)):
                self._done.add(service)
                return True
            future = None
        asked = self._recorded(service)
        if not asked and service not in self.required:
            self._done.add(service)              # records none of these topics
            return True
        if future is None or time.monotonic() - sent > RESEND_PERIOD:
            client = self._clients.get(service)
            if client is None:
                client = self._clients[service] = self.node.create_client(
                    MatchedPublishers, service, callback_group=self.callback_group)
            if client.service_is_ready():
                request = MatchedPublishers.Request(topics=asked)
                self._pending[service] = (client.call_async(request), asked, time.monotonic())
        return False


def _full_name(namespace: str, name: str) -> str:
    return namespace.rstrip('/') + '/' + name
