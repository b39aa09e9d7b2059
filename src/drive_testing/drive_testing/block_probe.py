"""A test subscriber that turns a telemetry block topic back into per-sample messages.

Tests that check every sample read the full-rate blocks (the per-sample live
topics are decimated, docs/architecture.md "Telemetry: blocks and live
topics"); :func:`drive_common.telemetry_blocks.expand` restores the
messages the node would have published per sample, bit-exact.
"""
from __future__ import annotations

from drive_common.telemetry_blocks import expand
from drive_common.topics import BLOCK_QOS


class BlockSamples:
    """Blocks of one topic as received, and their samples.

    blocks: the block messages; records: one tuple of per-sample messages
    per sample (status, measurement, command for a status block); first:
    the first message of each record (PlantState, DtcStatus, PfcStatus).
    """

    def __init__(self, node, block_type: type, topic: str) -> None:
        self.blocks: list = []
        self.records: list[tuple] = []
        self.first: list = []
        self.subscription = node.create_subscription(block_type, topic, self._on_block, BLOCK_QOS)

    def _on_block(self, block) -> None:
        self.blocks.append(block)
        records = list(expand(block))
        self.records.extend(records)
        self.first.extend(record[0] for record in records)


def same_bits(msg, sample) -> bool:
    """msg carries every field of sample (a core sample or a message) bit for bit.

    The header is msg's own (check stamps separately); the comparison is on
    the serialized bytes, so NaN payloads and signed zeros count.
    """
    from rclpy.serialization import serialize_message

    from drive_common.conversions import ReusedMessage
    expected = ReusedMessage(type(msg)).fill(sample)
    expected.header = msg.header
    return serialize_message(expected) == serialize_message(msg)
