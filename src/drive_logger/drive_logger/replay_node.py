"""Replay node: publish a bag's messages in sim time.

Messages are published as the exact recorded CDR bytes, in log-time order,
paced by their recorded log times divided by ``rate``. /clock follows the
bag: its recorded /clock messages if it has them, otherwise a /clock built
from each message's header stamp (sim time) whenever it advances, so
``use_sim_time`` nodes follow the recorded sim time.

Parameters (read at start):
- ``bag`` (string, required): bag directory (or .mcap file).
- ``rate`` (double, 1.0): speed factor; <= 0 publishes as fast as possible.
- ``loop`` (bool, false): start over at the end.
- ``topics`` (string[], []): topics to replay (default all).
- ``remap`` (string[], []): ``from:=to`` topic renames (``--ros-args -r`` works too).
- ``publish_clock`` (bool, true), ``salvage`` (bool, false: replay the intact
  part of a truncated or corrupt bag instead of failing),
  ``wait_for_subscribers`` (double s, 0.0: wait up to this long for at least
  one subscriber on every replayed topic before starting).
- ``start_offset`` (double s, 0.0): skip the first seconds of log time.
A bag that cannot be read is an error naming the problem (exit code 2).
"""
from __future__ import annotations

import struct
import sys
import time

import rclpy
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from drive_logger import ros_types
from drive_logger.bag_reader import BagReadError, BagReader
from drive_logger.message_definitions import cdr_stamp_ns as header_stamp_ns  # noqa: F401 (compare_replay)
from drive_logger.message_definitions import first_field_is_header as has_header, message_text

CLOCK_TOPIC = '/clock'


def clock_cdr(stamp_ns: int) -> bytes:
    """CDR bytes of rosgraph_msgs/Clock at stamp_ns."""
    sec, nanosec = divmod(stamp_ns, 1_000_000_000)
    return b'\x00\x01\x00\x00' + struct.pack('<iI', sec, nanosec)


def parse_remaps(items) -> dict[str, str]:
    out = {}
    for item in items:
        src, sep, dst = item.partition(':=')
        if not sep or not src or not dst:
            raise ValueError(f'remap {item!r} is not from:=to')
        out[src] = dst
    return out


class ReplayNode(Node):
    """Publishes one bag (see module docstring)."""

    def __init__(self, **kwargs) -> None:
        super().__init__('replay', **kwargs)
        ro = ParameterDescriptor(read_only=True)
        self.declare_parameter('bag', '', ro)
        self.declare_parameter('rate', 1.0, ro)
        self.declare_parameter('loop', False, ro)
        self.declare_parameter('topics', [''], ro)
        self.declare_parameter('remap', [''], ro)
        self.declare_parameter('publish_clock', True, ro)
        self.declare_parameter('salvage', False, ro)
        self.declare_parameter('wait_for_subscribers', 0.0, ro)
        self.declare_parameter('start_offset', 0.0, ro)   # s into the bag to start at (ros2 bag play --start-offset)
        get = lambda name: self.get_parameter(name).value  # noqa: E731
        if not get('bag'):
            raise BagReadError('parameter bag is required (bag directory or .mcap file)')
        self.reader = BagReader(get('bag'), salvage=get('salvage'))
        for problem in self.reader.problems:
            self.get_logger().warning(f'salvaging: {problem}')
        self.rate = float(get('rate'))
        self.loop = bool(get('loop'))
        self.wait_for_subscribers = float(get('wait_for_subscribers'))
        self.start_offset_ns = round(float(get('start_offset')) * 1e9)
        selected = [t for t in get('topics') if t]
        remaps = parse_remaps([r for r in get('remap') if r])
        infos = self.reader.topics
        self.topic_names = [t for t in infos if not selected or t in selected or t.lstrip('/') in selected]
        self.publishers_by_topic = {}
        self.stamped = {}
        for name in self.topic_names:
            info = infos[name]
            target = remaps.get(name, remaps.get(name.lstrip('/'), name))
            self.publishers_by_topic[name] = self.create_publisher(
                ros_types.message_class(info.type), target, ros_types.replay_qos(info.qos_profiles))
        self.publish_clock = bool(get('publish_clock'))
        self.synthesize_clock = self.publish_clock and CLOCK_TOPIC not in self.topic_names
        if self.synthesize_clock:
            from rosgraph_msgs.msg import Clock
            self.clock_publisher = self.create_publisher(Clock, CLOCK_TOPIC, 10)
        self.published = 0

    def _header_topics(self) -> set[str]:
        topics = set()
        for schema_name in {self.reader.topics[t].type for t in self.topic_names}:
            try:
                if has_header(message_text(schema_name)):
                    topics.update(t for t in self.topic_names if self.reader.topics[t].type == schema_name)
            except LookupError:
                pass
        return topics

    def _wait_for_subscribers(self) -> None:
        deadline = time.monotonic() + self.wait_for_subscribers
        while time.monotonic() < deadline and rclpy.ok(context=self.context):
            if all(p.get_subscription_count() > 0 for p in self.publishers_by_topic.values()):
                return
            time.sleep(0.02)
        self.get_logger().warning('not every replayed topic has a subscriber; starting anyway')

    def play_once(self) -> None:
        """Publish the bag once, paced by log time / rate."""
        stamped = self._header_topics() if self.synthesize_clock else set()
        last_clock = None
        wall0 = bag0 = first = None
        for msg in self.reader.messages(self.topic_names):
            if not rclpy.ok(context=self.context):
                return
            first = msg.log_time if first is None else first
            if msg.log_time - first < self.start_offset_ns:
                continue
            if self.rate > 0:
                if wall0 is None:
                    wall0, bag0 = time.monotonic(), msg.log_time
                delay = wall0 + (msg.log_time - bag0) * 1e-9 / self.rate - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
            if msg.topic in stamped:
                stamp = header_stamp_ns(msg.data)
                if last_clock is None or stamp > last_clock:
                    self.clock_publisher.publish(clock_cdr(stamp))
                    last_clock = stamp
            self.publishers_by_topic[msg.topic].publish(msg.data)
            self.published += 1

    def play(self) -> None:
        if self.wait_for_subscribers > 0:
            self._wait_for_subscribers()
        while rclpy.ok(context=self.context):
            self.play_once()
            if not self.loop:
                break
        self.get_logger().info(f'replay done: {self.published} messages published')


def main(args=None) -> int:
    rclpy.init(args=args)
    try:
        node = ReplayNode()
    except (BagReadError, ValueError, ros_types.UnknownTypeError, ParameterException) as exc:
        print(f'[replay] error: {exc}', file=sys.stderr, flush=True)
        rclpy.try_shutdown()
        return 2
    try:
        node.play()
        time.sleep(0.2)  # let the last reliable samples go out
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
