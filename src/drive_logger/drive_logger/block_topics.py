"""A bag's per-sample topics, taken from its block topics where it has them.

A block topic carries every sample of the per-sample topics of its parts
(:data:`drive_common.telemetry_blocks.BLOCK_PARTS`); a reader takes such a topic from the block
whenever the bag holds it, never mixed with recorded messages of that name. A sample's log time
is the block's plus its stamp offset (docs/architecture.md "Telemetry: blocks and live topics").
"""
from __future__ import annotations

import heapq
from typing import Iterable, Iterator

from rclpy.serialization import deserialize_message, serialize_message

from drive_common import topics as names
from drive_common.telemetry_blocks import BLOCK_PARTS, expand, sample_stamps_ns, step_gaps
from drive_logger import ros_types
from drive_logger.bag_reader import BagMessage, BagReader, BagReadError
from drive_logger.message_definitions import normalize_type_name


BLOCK_TOPICS: dict[str, tuple[str, tuple[str, ...]]] = {
    '/' + names.PLANT_STATE_BLOCK: ('dtc_msgs/msg/PlantStateBlock', ('/' + names.PLANT_STATE,)),
    '/' + names.DTC_STATUS_BLOCK: ('dtc_msgs/msg/DtcStatusBlock', (
        '/' + names.DTC_STATUS, '/' + names.DRIVE_MEASUREMENT, '/' + names.GATE_COMMAND)),
    '/' + names.PFC_STATUS_BLOCK: ('dtc_msgs/msg/PfcStatusBlock', (
        '/' + names.PFC_STATUS, '/' + names.PFC_MEASUREMENT, '/' + names.DUTY_COMMAND)),
}
"""Block topic -> (block type, the per-sample topics of its parts in BLOCK_PARTS order: status, measurement, command)."""

PUBLISH_ORDER = (2, 0, 1)
"""Part index -> place within one sample as the graph publishes it: measurement, command, status."""


def block_sources(reader: BagReader) -> dict[str, tuple[str, int]]:
    """{per-sample topic: (block topic, part index)} for every block topic the bag holds messages of
    (BagReadError for a block topic recorded with another type)."""
    out = {}
    for block_topic, (block_type, parts) in BLOCK_TOPICS.items():
        info = reader.topics.get(block_topic)
        if info is None or info.message_count == 0:
            continue
        if normalize_type_name(info.type) != block_type:
            raise BagReadError(f'bag {str(reader.path)!r}: topic {block_topic} has type {info.type}, '
                               f'not {block_type}')
        for index, topic in enumerate(parts):
            out[topic] = (block_topic, index)
    return out


def split_namespace(topic: str) -> tuple[str, str] | None:
    """(namespace, block topic) of a block topic recorded under a drive's namespace
    (``/drive1/plant/state_block`` -> ``('/drive1', '/plant/state_block')``; '' for none),
    or None if topic is no block topic."""
    for block_topic in BLOCK_TOPICS:
        if topic.endswith(block_topic):
            return topic[:-len(block_topic)], block_topic
    return None


def block_class(block_topic: str) -> type:
    """The generated block message class of a block topic."""
    return ros_types.message_class(BLOCK_TOPICS[block_topic][0])


def part_classes(block_topic: str) -> list[type]:
    """Per-sample message classes of a block topic's parts (BLOCK_PARTS order)."""
    return [msg_type for _, msg_type in BLOCK_PARTS[block_class(block_topic)]]


def per_sample_messages(reader: BagReader, topics: Iterable[str] | None = None) -> Iterator[BagMessage]:
    """The bag's messages of `topics` (None: every topic, blocks replaced by their per-sample topics).

    A wanted topic a block carries is expanded from it, others read as recorded; in log-time
    order (ties: recorded first, then a block's samples in PUBLISH_ORDER).
    """
    sources = block_sources(reader)
    every = topics is None
    wanted = set(reader.topics) | set(sources) if every else set(topics)
    expanded: dict[str, list[tuple[int, str]]] = {}      # block topic -> [(part, topic)]
    for topic, (block_topic, part) in sources.items():
        if topic in wanted:
            expanded.setdefault(block_topic, []).append((part, topic))
    recorded = {t for t in reader.topics if t in wanted and t not in sources
                and not (every and t in expanded)}
    block_classes = {b: block_class(b) for b in expanded}
    part_names = {b: [ros_types.type_name(c) for c in part_classes(b)] for b in expanded}
    pending: list = []                      # heap of (log_time, tie, seq, BagMessage)
    seq = 0
    for msg in reader.messages(sorted(recorded | set(expanded))):
        while pending and pending[0][0] < msg.log_time:
            yield heapq.heappop(pending)[3]
        if msg.topic in recorded:
            yield msg
        if msg.topic not in expanded:
            continue
        block = deserialize_message(msg.data, block_classes[msg.topic])
        stamps = sample_stamps_ns(block)
        offsets = (stamps - stamps[0]).tolist() if block.count else []
        for i, parts in enumerate(expand(block)):
            log_time = msg.log_time + offsets[i]
            publish_time = msg.publish_time + offsets[i]
            for part, topic in expanded[msg.topic]:
                seq += 1
                data = bytes(serialize_message(parts[part]))
                heapq.heappush(pending, (log_time, PUBLISH_ORDER[part], seq, BagMessage(
                    topic, part_names[msg.topic][part], log_time, publish_time, data, 0)))
    while pending:
        yield heapq.heappop(pending)[3]


def read_blocks(reader: BagReader, block_topics: Iterable[str]) -> dict[str, list]:
    """{block topic: its block messages in log-time order} (deserialized to the generated classes)."""
    block_topics = list(block_topics)
    classes = {b: block_class(b) for b in block_topics}
    blocks: dict[str, list] = {b: [] for b in block_topics}
    for msg in reader.messages(block_topics):
        blocks[msg.topic].append(deserialize_message(msg.data, classes[msg.topic]))
    return blocks


def block_summaries(reader: BagReader) -> dict[str, tuple[int, list[str]]]:
    """{block topic: (samples, problems)} of the bag's block topics; problems: skipped or
    repeated steps between consecutive blocks (telemetry_blocks.step_gaps)."""
    present = sorted({block for block, _ in block_sources(reader).values()})
    return {topic: (sum(b.count for b in blocks), step_gaps(blocks))
            for topic, blocks in read_blocks(reader, present).items()}
