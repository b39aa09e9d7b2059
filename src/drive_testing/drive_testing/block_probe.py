"""A test subscriber that turns a telemetry block topic back into per-sample messages, bit-exact
(:func:`drive_common.telemetry_blocks.expand`): tests that check every sample read the blocks."""
from __future__ import annotations

import array
import struct

import numpy as np

from drive_common.telemetry_blocks import expand
from drive_common.topics import BLOCK_QOS


class BlockSamples:
    """Blocks of one topic as received (blocks), a tuple of per-sample messages per sample (records:
    status, measurement, command for a status block) and each record's first message (first)."""

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


def _bits(value):
    """A value in comparable form: floats by their IEEE-754 bytes (NaN payloads, signed zeros)."""
    if hasattr(value, 'get_fields_and_field_types'):
        return message_bits(value)
    if isinstance(value, float):
        return struct.pack('<d', value)
    if isinstance(value, np.ndarray):
        return value.dtype.str, value.tobytes()
    if isinstance(value, array.array):
        return value.typecode, value.tobytes()
    if isinstance(value, (list, tuple)):
        return tuple(_bits(v) for v in value)
    return value


def message_bits(msg) -> tuple:
    """Every field of msg, header included, as comparable bits (equal iff bit-identical; not the
    serialized bytes, whose CDR padding need not be zero)."""
    return tuple((name, _bits(getattr(msg, name))) for name in msg.get_fields_and_field_types())


def same_bits(msg, sample) -> bool:
    """msg carries every field of sample (a core sample or a message) bit for bit, header excepted."""
    from drive_common.conversions import ReusedMessage
    expected = ReusedMessage(type(msg)).fill(sample)
    expected.header = msg.header
    return message_bits(expected) == message_bits(msg)
