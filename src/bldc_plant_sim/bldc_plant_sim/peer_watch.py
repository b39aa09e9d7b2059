"""Peer waiting and binding of the plant node: who answers, who intrudes, who is missing.

docs/architecture.md "Time and lockstep": sim time starts once every controller due in the run
is matched (up to ``startup_timeout``). Before any controller is bound a second graph in the
domain makes the node exit 2; after, each command topic is bound to the controller that answers
first (:mod:`drive_common.peer_binding`), any other publisher ignored and reported once.
"""
from __future__ import annotations

import time

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup

from bldc_plant_sim.core.lockstep import ControllerKind
from bldc_plant_sim.lockstep_loop import CHANNELS, WaitReporter
from drive_common.domain_guard import wait_for_stable_graph
from drive_common.lockstep_io import GraphConflict, graph_conflict, unmatched_topics
from drive_common.recorder_matching import RecordersMatched
from drive_common.waiting import wait_until

GRAPH_CHECK_PERIOD = 0.5        # s between checks for a second graph in the domain
READERS_MATCH_WAIT = 20.0       # s a run's start waits at most for the graph's readers to match
LOCKSTEP_TOPICS = (tuple(spec.measurement_topic for spec in CHANNELS.values())
                   + tuple(spec.command_topic for spec in CHANNELS.values()))
"""One publisher each, or two graphs are mixed."""


def _unknown_node(name: str, namespace: str) -> bool:
    """A graph endpoint of a node the graph no longer knows (rmw placeholder names)."""
    return name.startswith('_NODE_NAME_UNKNOWN') or namespace.startswith('_NODE_NAMESPACE_UNKNOWN')


class PeerWatch:
    """Mixin of :class:`~bldc_plant_sim.plant_node.PlantNode`: peers awaited, bound, named."""

    def _watch_graph(self) -> None:
        """Check for a second graph in the domain every GRAPH_CHECK_PERIOD s."""
        self.create_timer(GRAPH_CHECK_PERIOD, self._check_graph,
                          callback_group=MutuallyExclusiveCallbackGroup())

    def _sources(self, which: ControllerKind) -> str:
        """The node(s) publishing this controller's commands, for a diagnostic (one that left
        the graph named as the last one seen)."""
        channel = getattr(self, '_channels', {}).get(which)
        if channel is not None and channel.binding.bound:
            self._last_sources[which] = channel.binding.peer_name
            return channel.binding.peer_name
        infos = self.get_publishers_info_by_topic(CHANNELS[ControllerKind(which)].command_topic)
        names = ', '.join(sorted({(i.node_namespace.rstrip('/') + '/' + i.node_name) for i in infos
                                  if not _unknown_node(i.node_name, i.node_namespace)}))
        if names:
            self._last_sources[which] = names
            return names
        last = self._last_sources.get(which) or ('unknown node' if infos else None)
        if infos:
            return f'{last} (leaving)'
        return f'no publisher; last seen: {last}, gone' if last else 'no publisher'

    def _graph_conflict(self) -> str | None:
        """A second graph in the domain, or None (once a controller is bound: intruders reported)."""
        bindings = [channel.binding for channel in self._channels.values()]
        if any(b.bound for b in bindings):
            for binding in bindings:
                binding.check()
            return None
        return graph_conflict(self, LOCKSTEP_TOPICS)

    def _check_graph(self) -> None:
        """A second graph in the domain: stop the run and refuse to go on (exit 2)."""
        if self._refused:
            return
        reason = self._conflict or self._graph_conflict()
        if reason:
            self._conflict, self._refused = reason, True
            raise GraphConflict(reason)      # once: run_node reports it and exits 2

    def _wait_for_recorders(self, outputs, deadline: float, report: WaitReporter) -> None:
        """Before the first run, until every recorder in the graph matched the plant's publishers
        from its own side (drive_common.recorder_matching)."""
        matched = RecordersMatched(self, [p.topic_name for p in outputs],
                                   callback_group=MutuallyExclusiveCallbackGroup())

        def done() -> bool:
            if matched() or self._halted():
                return True
            report.report('recorder(s) ' + ', '.join(matched.waiting_for) + ' to match the plant')
            return False
        try:
            if not wait_until(done, max(0.0, deadline - time.monotonic()),
                              0.01, pause=self._receiver.poll, raise_timeout=False):
                self.get_logger().warning('recorder(s) ' + ', '.join(matched.waiting_for) + ' had not '
                                          'matched the plant before the run: they miss its first samples')
        finally:
            matched.destroy()

    def _wait_for_peers(self, deadline: float, report: WaitReporter) -> str | None:
        """Wait until every required controller is matched; None or the reason it failed."""
        needs = []
        for channel in self._scheduled_channels():
            spec = channel.spec
            needs += [(channel.publisher.get_subscription_count,
                       f'a subscriber of {spec.measurement_topic}'),
                      (channel.subscription.get_publisher_count, f'a publisher of {spec.command_topic}')]
        while True:
            missing = [what for count, what in needs if count() < 1]
            if not missing:
                break
            halted = self._halted()
            if halted:
                return halted
            if time.monotonic() > deadline:
                return (f'no controller matched within startup_timeout = '
                        f'{self.parameters["startup_timeout"]:g} s: missing ' + ', '.join(missing))
            report.report('the controllers to start: missing ' + ', '.join(missing))
            self._receiver.poll(0.01)
        # Other subscribers in the graph (recorders) are matched too before sample 0 goes out
        # (the first run waits for a settled graph); one that never matches is left behind.
        first_run = not self._graph_settled
        waits_began = time.monotonic()
        if first_run:
            if not wait_for_stable_graph(self, stop=lambda: self._halted() is not None):
                return self._halted() or 'plant shutting down'   # Ctrl-C, shutdown, a second graph
            self._graph_settled = True
        outputs = [c.publisher for c in self._channels.values()] + [self._state_pub, self._block_pub]
        readers_deadline = time.monotonic() + READERS_MATCH_WAIT
        readers_report = WaitReporter(self.get_logger(), f'(at most {READERS_MATCH_WAIT:g} s)')

        def matched() -> bool:
            unmatched = unmatched_topics(self, outputs)
            if not unmatched or self._halted():
                return True
            readers_report.report('the subscribers in the graph to match: ' + ', '.join(unmatched))
            return False
        if not wait_until(matched, READERS_MATCH_WAIT, 0.01, pause=self._receiver.poll,
                          raise_timeout=False):
            self.get_logger().warning(
                f'subscriber(s) of {", ".join(unmatched_topics(self, outputs))} did not match the '
                f'plant within {READERS_MATCH_WAIT:g} s (gone, or asking for a QoS it does not '
                'offer): the run starts without them')
        if first_run:
            self._wait_for_recorders(outputs + [self._clock_pub], readers_deadline, readers_report)
        # startup_timeout counts the controllers' start-up, not discovery and readers.
        self._run_started += time.monotonic() - waits_began
        for channel in self._scheduled_channels():
            self._sources(channel.kind)          # remembered, should a controller leave mid-run
        conflict = self._graph_conflict()
        if conflict:
            self._conflict = conflict            # the check timer makes the node exit 2
        return conflict
