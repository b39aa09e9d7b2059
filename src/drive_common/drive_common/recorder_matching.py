"""Whether the recorders in the graph have matched a node's publishers from their own side.

DDS discovery is one-sided for a moment, so the plant and the runner ask each recorder's
``~/matched_publishers`` service (dtc_msgs/srv/MatchedPublishers) until it covers every publisher.
"""
from __future__ import annotations

import time
from typing import Iterable

from drive_common.namespaces import full_name

SERVICE_SUFFIX = '/matched_publishers'
SERVICE_TYPE = 'dtc_msgs/srv/MatchedPublishers'
RESEND_PERIOD = 1.0   # s: a request unanswered this long is sent again (a reply to a new client can be lost)


class RecordersMatched:
    """A predicate, polled: True once every recorder (and ``required`` service) has matched every
    publisher of the topics it subscribes; an executor must serve ``callback_group`` meanwhile."""

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
                if any(full_name(i.node_name, i.node_namespace) == recorder
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
