"""Replay node: publish a bag's messages in sim time (docs/bags.md "Reading a bag again").

The recorded CDR bytes in log-time order, paced by log time / ``rate``; /clock as recorded,
else from each stamped message's header whenever it advances; ``expand_blocks``: the
per-sample topics of the block topics instead of the blocks, bit-exact; ``namespace``: one
drive of several. Parameters: :data:`REPLAY_SCHEMA`. An unreadable bag: exit code 2.
"""
from __future__ import annotations

import struct
import sys
import threading
import time

from rclpy.duration import Duration
from rclpy.node import Node
from rosgraph_msgs.msg import Clock

from drive_common.node_main import run_node
from drive_common.parameters import ParameterSpec, schema
from drive_common.ros_parameters import SchemaParameters
from drive_common.topics import CLOCK
from drive_common.waiting import wait_until

from drive_logger import ros_types
from drive_logger.bag_reader import BagReadError, BagReader
from drive_logger.block_topics import block_sources, part_classes, per_sample_messages
from drive_logger.message_definitions import carries_sim_stamp, cdr_stamp_ns


def clock_cdr(stamp_ns: int) -> bytes:
    """CDR bytes of rosgraph_msgs/Clock at stamp_ns."""
    sec, nanosec = divmod(stamp_ns, 1_000_000_000)
    return b'\x00\x01\x00\x00' + struct.pack('<iI', sec, nanosec)


def parse_remaps(items) -> dict[str, str]:
    """{from: to} of 'from:=to' items."""
    out = {}
    for item in items:
        src, sep, dst = item.partition(':=')
        if not sep or not src or not dst:
            raise ValueError(f'remap {item!r} is not from:=to')
        out[src] = dst
    return out


REPLAY_SCHEMA = schema([
    ParameterSpec('bag', '', 'bag directory or .mcap file (required)'),
    ParameterSpec('rate', 1.0, 'speed factor (<= 0: as fast as possible)', '', -1e6, 1e6),
    ParameterSpec('loop', False, 'start over at the end'),
    ParameterSpec('topics', [''], "topics to replay (['']: all)"),
    ParameterSpec('remap', [''], 'from:=to topic renames'),
    ParameterSpec('publish_clock', True, 'publish /clock (recorded, or from the header stamps)'),
    ParameterSpec('salvage', False, 'replay the intact part of a truncated or corrupt bag'),
    ParameterSpec('wait_for_subscribers', 0.0, 'wait up to this long for a subscriber on every topic',
                  's', 0.0, 3600.0),
    ParameterSpec('start_offset', 0.0, 'start this far into the bag (log time; ros2 bag play --start-offset)',
                  's', 0.0, 1e9),
    ParameterSpec('expand_blocks', False, 'publish the per-sample topics from the block topics instead of the blocks'),
    ParameterSpec('namespace', '', "the drive's namespace in a bag of several ('': the only one)"),
], read_only=True)


class ReplayNode(Node):
    """Publishes one bag (see module docstring)."""

    def __init__(self, **kwargs) -> None:
        super().__init__('replay', **kwargs)
        get = self.parameters = SchemaParameters(self, REPLAY_SCHEMA)
        if not get['bag']:
            raise BagReadError('parameter bag is required (bag directory or .mcap file)')
        self.reader = BagReader(get['bag'], salvage=get['salvage'],
                                namespace=get['namespace'] or 'auto')
        for problem in self.reader.problems:
            self.get_logger().warning(f'salvaging: {problem}')
        self.rate = float(get['rate'])
        self.loop = bool(get['loop'])
        self.wait_for_subscribers = float(get['wait_for_subscribers'])
        self.start_offset_ns = round(float(get['start_offset']) * 1e9)
        selected = [t for t in get['topics'] if t]
        remaps = parse_remaps([r for r in get['remap'] if r])
        self.expand_blocks = bool(get['expand_blocks'])
        available = self._available_topics()
        self.topic_types = {t: available[t][0] for t in available
                            if not selected or t in selected or t.lstrip('/') in selected}
        self.topic_names = list(self.topic_types)
        self.publishers_by_topic = {}
        for name in self.topic_names:
            type_name, profiles = available[name]
            # A namespaced drive's topics: relative, under this node's namespace.
            default = name.lstrip('/') if self.reader.namespace else name
            target = remaps.get(name, remaps.get(name.lstrip('/'), default))
            self.publishers_by_topic[name] = self.create_publisher(
                ros_types.message_class(type_name), target, ros_types.replay_qos(profiles))
        self.publish_clock = bool(get['publish_clock'])
        self.synthesize_clock = self.publish_clock and CLOCK not in self.topic_names
        if self.synthesize_clock:
            self.clock_publisher = self.create_publisher(Clock, CLOCK, 10)
        self.published = 0

    def _available_topics(self) -> dict[str, tuple[str, list]]:
        """{topic: (type, offered QoS profiles)} this replay can publish."""
        infos = self.reader.topics
        topics = {name: (info.type, info.qos_profiles) for name, info in infos.items()}
        if self.expand_blocks:
            for topic, (block_topic, part) in block_sources(self.reader).items():
                topics.pop(block_topic, None)
                msg_type = part_classes(block_topic)[part]
                topics[topic] = (ros_types.type_name(msg_type), infos[block_topic].qos_profiles)
        return topics

    def play_once(self, stop: threading.Event) -> None:
        """Publish the bag once, paced by log time / rate, until stop is set."""
        stamped = {t for t, n in self.topic_types.items() if _stamped(n)} if self.synthesize_clock else set()
        last_clock = None
        wall0 = bag0 = first = None
        messages = (per_sample_messages(self.reader, self.topic_names) if self.expand_blocks
                    else self.reader.messages(self.topic_names))
        for msg in messages:
            if stop.is_set():
                return
            first = msg.log_time if first is None else first
            if msg.log_time - first < self.start_offset_ns:
                continue
            if self.rate > 0:
                if wall0 is None:
                    wall0, bag0 = time.monotonic(), msg.log_time
                delay = wall0 + (msg.log_time - bag0) * 1e-9 / self.rate - time.monotonic()
                if delay > 0 and stop.wait(delay):
                    return
            if msg.topic in stamped:
                stamp = cdr_stamp_ns(msg.data)
                if last_clock is None or stamp > last_clock:
                    self.clock_publisher.publish(clock_cdr(stamp))
                    last_clock = stamp
            self.publishers_by_topic[msg.topic].publish(msg.data)
            self.published += 1

    def play(self, stop: threading.Event) -> None:
        """Publish the bag (again and again with ``loop``) until done or stop is set."""
        if self.wait_for_subscribers > 0 and not wait_until(lambda: stop.is_set() or all(
                p.get_subscription_count() > 0 for p in self.publishers_by_topic.values()),
                self.wait_for_subscribers, 0.02, raise_timeout=False):
            self.get_logger().warning('not every replayed topic has a subscriber; starting anyway')
        while not stop.is_set():
            self.play_once(stop)
            if not self.loop:
                break
        self.get_logger().info(f'replay done: {self.published} messages published')
        self._wait_for_acks(stop)

    def _wait_for_acks(self, stop: threading.Event, timeout: float = 5.0) -> None:
        """Let the last reliable samples (and any a late-matching reader asks again for) go out."""
        deadline = time.monotonic() + timeout
        for publisher in self.publishers_by_topic.values():
            left = deadline - time.monotonic()
            if stop.is_set() or left <= 0 or not publisher.wait_for_all_acked(Duration(seconds=left)):
                break
        stop.wait(0.2)


def _stamped(type_name: str) -> bool:
    """Whether its messages lead with their sample's sim stamp (a type not installed: no)."""
    try:
        return carries_sim_stamp(type_name)
    except LookupError:
        return False


def main(args=None) -> int:
    return run_node(ReplayNode, args, work=ReplayNode.play,
                    errors=(BagReadError, ValueError, ros_types.UnknownTypeError))


if __name__ == '__main__':
    sys.exit(main())
