"""Recorder node: record topics of the drive graph into a rosbag2-layout MCAP bag.

Raw subscriptions, taken in the node's own wait loop, hand their CDR bytes (made canonical
unless canonical at the source) to a :class:`drive_logger.sample_topics.CanonicalWriter`, so
two recordings of one scenario are byte-identical files. Subscriptions exist once it logs
``recorder ready``. Parameters: :data:`RECORDER_SCHEMA`. SIGINT/SIGTERM: drain, finalize,
exit 0; a bad output or topic type: exit 2 at start.
"""
from __future__ import annotations

import sys
import threading
import time

from rcl_interfaces.msg import ParameterEvent
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy, DurabilityPolicy
from rclpy.serialization import deserialize_message

from dtc_msgs.srv import MatchedPublishers

from drive_common.cdr_padding import canonicalize
from drive_common.lockstep_io import DirectCallbackGroup, DirectReceiver, GraphConflict, graph_conflict
from drive_common.node_main import run_node
from drive_common.parameters import ParameterSpec, schema
from drive_common.ros_parameters import SchemaParameters
from drive_common.waiting import wait_until
from drive_logger import graph_topics, ros_types
from drive_logger.bag_writer import LOG_TIME_SOURCES, BagWriteError, BagWriter, SimTimeLog
from drive_common.telemetry import DEFAULT_LIVE_PERIOD
from drive_logger.sample_topics import CanonicalWriter, SampleTopics
from drive_logger.message_definitions import (NO_STAMP, DefinitionNotFoundError, normalize_type_name,
                                              sim_stamp_kind, type_definition)


class RecorderConfigError(RuntimeError):
    """Bad recorder configuration detected at start (nothing was written)."""


class _Topic:
    """A recorded topic: subscription, type and (once the first message came) bag record."""

    __slots__ = ('name', 'type_name', 'definition', 'subscription', 'record', 'stamp_kind', 'canonical_of',
                 'paced')

    def __init__(self, name, type_name, definition):
        self.name, self.type_name, self.definition = name, type_name, definition
        self.stamp_kind = sim_stamp_kind(type_name) if definition is not None else NO_STAMP
        self.paced = definition is not None and graph_topics.is_paced(type_name)
        # the message class whose bytes need canonicalize(); None: canonical at the source
        self.canonical_of = (None if definition is None or type_name in graph_topics.CANONICAL_AT_SOURCE_TYPES
                             else ros_types.message_class(type_name))
        self.subscription = None
        self.record = None


PARAMETER_EVENT_TYPE = 'rcl_interfaces/msg/ParameterEvent'


def _declares_only(data: bytes) -> bool:
    """A parameter event that only declares parameters: sent as a node starts, so whether a
    recorder hears it depends on discovery timing; not recorded (two runs give one bag)."""
    try:
        event = deserialize_message(data, ParameterEvent)
    except Exception:  # noqa: BLE001 - malformed CDR: recorded as it came (see _canonical)
        return False
    return not event.changed_parameters and not event.deleted_parameters


RECORDER_SCHEMA = schema([
    ParameterSpec('topics', list(graph_topics.DEFAULT_TOPICS), 'topics to record: name or name:pkg/msg/Type'),
    ParameterSpec('all_topics', False, 'also record every topic that appears later'),
    ParameterSpec('output', '', "bag directory to create ('': bags/<YYYYmmdd-HHMMSS>)"),
    ParameterSpec('compression', 'lz4', 'MCAP chunk compression', choices=('lz4', 'zstd', 'none')),
    ParameterSpec('chunk_size', 1 << 20, 'MCAP chunk size', 'byte', 1, 1 << 30),
    ParameterSpec('qos_depth', 10000, 'KEEP_LAST depth of the subscriptions (0: KEEP_ALL)', '', 0, 1 << 20),
    ParameterSpec('type_discovery_timeout', 2.0, 'time to look up the type of a topic outside the drive graph',
                  's', 0.0, 60.0),
    ParameterSpec('drain_timeout', 2.0, 'at stop, take queued messages for at most this long', 's', 0.0, 60.0),
    ParameterSpec('batch_period', 0.005, 'rest after a wake-up that took messages', 's', 0.0, 0.1),
    ParameterSpec('log_time', 'sim', "clock of the bag's log times: 'sim' (sample stamps) or 'wall'",
                  choices=LOG_TIME_SOURCES),
    ParameterSpec('flush_period', 0.5, 'close the chunk and fsync at least this often (wall time)', 's', 0.01, 60.0),
    ParameterSpec('viewer_topics', True, 'add per-sample viewer topics (plant/state, dtc/status, pfc/status) '
                  'derived from the blocks'),
    ParameterSpec('viewer_period', DEFAULT_LIVE_PERIOD, 'sim time between samples of the viewer topics; 0 = every sample',
                  's', 0.0, 1.0),
], read_only=True)


class RecorderNode(Node):
    """Subscribes (raw) to the chosen topics and streams their messages into a bag."""

    def __init__(self, **kwargs) -> None:
        super().__init__('recorder', **kwargs)
        p = self.parameters = SchemaParameters(self, RECORDER_SCHEMA)
        self.flush_period = float(p['flush_period'])
        self.drain_timeout = float(p['drain_timeout'])
        self.batch_period = float(p['batch_period'])
        self.qos_depth = int(p['qos_depth'])
        self.all_topics = bool(p['all_topics'])
        self._lock = threading.Lock()
        self._not_spun = DirectCallbackGroup()   # subscriptions: taken by run(), not the executor
        # every topic and type resolved before the bag is created, then the subscriptions
        wanted = self._resolve_topics(p['topics'] or [], float(p['type_discovery_timeout']))
        output = p['output'] or str(graph_topics.default_output_dir())
        try:
            self.writer = BagWriter(output, compression=p['compression'], chunk_size=int(p['chunk_size']),
                                    log_time=p['log_time'])
        except BagWriteError as exc:
            raise RecorderConfigError(str(exc)) from exc
        viewer = SampleTopics(float(p['viewer_period'])) if p['viewer_topics'] else None
        self.bag = CanonicalWriter(self.writer, viewer, reserved=wanted)
        self.sim_log = SimTimeLog(self.bag) if p['log_time'] == 'sim' else None
        self.derived = set(viewer.topics_for(self.resolve_topic_name(t) for t in graph_topics.BLOCK_TOPICS)
                           ) - set(wanted) if viewer else set()
        self.topics: dict[str, _Topic] = {}
        for name, (type_name, definition) in wanted.items():
            self._subscribe(name, type_name, definition)
        self.create_service(MatchedPublishers, '~/matched_publishers', self._matched_publishers)
        self.get_logger().info(
            f'recorder ready: recording {len(self.topics)} topic(s) {sorted(self.topics)} '
            f'into {self.writer.path}')

    def _resolve_topics(self, specs, timeout: float) -> dict:
        resolved = {}
        unknown = []
        for spec in specs:
            try:
                name, type_name = graph_topics.parse_topic_spec(spec)
            except ValueError as exc:
                raise RecorderConfigError(str(exc)) from exc
            full = self.resolve_topic_name(name)
            if type_name is None:
                unknown.append(full)
            resolved[full] = type_name

        def all_known() -> bool:
            graph = dict(self.get_topic_names_and_types())
            for name in list(unknown):
                if graph.get(name):
                    resolved[name] = graph[name][0]
                    unknown.remove(name)
            return not unknown

        if not wait_until(all_known, timeout, 0.05, raise_timeout=False):
            raise RecorderConfigError(
                f'unknown type of topic(s) {unknown}: not part of the drive graph and not seen on the '
                f'graph within {timeout} s; give it as name:pkg/msg/Type')
        out = {}
        for name, type_name in resolved.items():
            ros_types.message_class(type_name)
            try:
                out[name] = (normalize_type_name(type_name), type_definition(type_name))
            except (DefinitionNotFoundError, ValueError) as exc:
                raise RecorderConfigError(f'topic {name!r}: {exc}') from exc
        return out

    def _subscription_qos(self, name: str) -> QoSProfile:
        # Reliable unless a publisher already known offers only best effort
        # (the plant's /clock is reliable, so nothing of it is lost either).
        best_effort = any(info.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT
                          for info in self.get_publishers_info_by_topic(name))
        reliability = ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE
        history = HistoryPolicy.KEEP_LAST if self.qos_depth > 0 else HistoryPolicy.KEEP_ALL
        return QoSProfile(history=history, depth=self.qos_depth or 1, reliability=reliability,
                          durability=DurabilityPolicy.VOLATILE)

    def _subscribe(self, name: str, type_name: str, definition) -> None:
        topic = _Topic(name, type_name, definition)
        topic.subscription = self.create_subscription(
            ros_types.message_class(type_name), name, self._callback_for(topic), self._subscription_qos(name),
            raw=True, callback_group=self._not_spun)
        self.topics[name] = topic

    def _matched_publishers(self, request, response):
        """Per requested topic, the publishers its subscription has matched (a runner waits for
        them before the run: a publisher matched only on its own side loses the first samples)."""
        topics = [self.topics.get(self.resolve_topic_name(t)) for t in request.topics]
        response.publishers = [t.subscription.get_publisher_count() if t and t.subscription else 0
                               for t in topics]
        return response

    def discover(self) -> None:
        for name, types in self.get_topic_names_and_types():
            if name in self.topics or not types:
                continue
            if name in self.derived:        # the bag has it from the blocks
                self.topics[name] = _Topic(name, types[0], None)
                continue
            try:
                ros_types.message_class(types[0])
                self._subscribe(name, normalize_type_name(types[0]), type_definition(types[0]))
                self.get_logger().info(f'recording discovered topic {name} ({types[0]})')
            except (ros_types.UnknownTypeError, DefinitionNotFoundError, ValueError) as exc:
                self.topics[name] = _Topic(name, types[0], None)  # remember, do not retry
                self.get_logger().warning(f'cannot record {name}: {exc}')

    def _offered_qos(self, topic: _Topic) -> list:
        return [ros_types.qos_to_dict(info.qos_profile) for info in self.get_publishers_info_by_topic(topic.name)]

    def _callback_for(self, topic: _Topic):
        bag = self.bag
        sim_log = self.sim_log
        declarations_only = _declares_only if topic.type_name == PARAMETER_EVENT_TYPE else None

        def on_message(data: bytes, info: dict) -> None:
            if declarations_only is not None and declarations_only(data):
                return
            if topic.canonical_of is not None:
                data = self._canonical(topic, data)
            with self._lock:
                if bag.closed:
                    return
                record = topic.record
                if record is None:
                    record = topic.record = bag.add_topic(topic.name, topic.definition, self._offered_qos(topic),
                                                          paced=topic.paced and sim_log is not None)
                if sim_log is not None:
                    sim_log.write(record, data, topic.stamp_kind)
                else:
                    bag.write(record, data, info['received_timestamp'], info['source_timestamp'])
        return on_message

    def _canonical(self, topic: _Topic, data: bytes) -> bytes:
        """data in canonical CDR; bytes that do not decode as the topic's type are kept as they came."""
        try:
            return canonicalize(data, topic.canonical_of)
        except Exception as exc:  # noqa: BLE001 - rclpy raises bare errors for malformed CDR
            self.get_logger().warning(f'{topic.name}: a message that does not decode as {topic.type_name} '
                                      f'is recorded as it came ({exc})', throttle_duration_sec=5.0)
            return data

    def end_of_wakeup(self) -> None:
        """Log the messages of this wake-up without a sim stamp at the sim time reached by it."""
        if self.sim_log is not None:
            with self._lock:
                self.sim_log.end_of_wakeup()

    def flush(self) -> None:
        """Write what every paced topic has passed (wall log times: all) and put it on disk."""
        with self._lock:
            watermark = (self.bag.watermark([t.name for t in self.topics.values() if t.paced])
                         if self.sim_log is not None else None)
            self.bag.flush(watermark, sync_in_background=True)

    def finalize(self) -> None:
        """Write everything, register silent topics (count 0) and close the bag."""
        self.end_of_wakeup()
        with self._lock:
            if self.bag.closed:
                return
            self.bag.close({t.name: (t.definition, self._offered_qos(t)) for t in self.topics.values()
                            if t.record is None and t.definition is not None})
        if self.bag.late:
            self.get_logger().warning(f'{self.bag.late} message(s) came after later ones had been written: '
                                      'the bag holds them out of log-time order')
        if self.bag.underived:
            self.get_logger().warning(f'{self.bag.underived} block(s) did not decode: no viewer messages from them')
        counts = {name: t.message_count for name, t in self.writer.topics.items()}
        self.get_logger().info(f'bag finalized: {self.writer.path} ({self.writer.message_count} messages: {counts})')


def run(node: RecorderNode, stop: threading.Event) -> None:
    """Record until stop is set, then take what is still queued and finalize the bag.

    Each wake-up takes every queued message of every subscription (drive_common.lockstep_io):
    the executor's one callback per wait costs more than the recording at the graph's rates.
    """
    receiver, subscriptions = None, []
    next_discovery = time.monotonic()
    next_flush = time.monotonic() + node.flush_period

    def spin_once() -> int:
        nonlocal next_flush, receiver, subscriptions
        current = [t.subscription for t in node.topics.values() if t.subscription]
        if current != subscriptions:      # topics discovered since the last wait
            subscriptions = current
            receiver = DirectReceiver(node.context, current, with_info=True)
        taken = receiver.poll(min(0.1, node.flush_period))
        node.end_of_wakeup()
        if time.monotonic() >= next_flush:
            node.flush()
            next_flush = time.monotonic() + node.flush_period
        return taken

    try:
        while not stop.is_set():
            if spin_once() and node.batch_period > 0.0:
                stop.wait(node.batch_period)
            if time.monotonic() >= next_discovery:
                conflict = graph_conflict(node)      # a second /recorder: two graphs mixed
                if conflict:
                    raise GraphConflict(conflict)    # the bag is finalized; run_node exits 2
                if node.all_topics:
                    node.discover()
                next_discovery = time.monotonic() + 0.5
        wait_until(lambda: not spin_once(), node.drain_timeout, 0.0,
                   raise_timeout=False)   # until a wake-up takes nothing, or drain_timeout
    finally:
        node.finalize()


def main(args=None) -> int:
    return run_node(RecorderNode, args, work=run, errors=(RecorderConfigError, ros_types.UnknownTypeError))


if __name__ == '__main__':
    sys.exit(main())
