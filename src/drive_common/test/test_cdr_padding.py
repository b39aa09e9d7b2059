"""serialize_zero_padded: the same values as rclpy's serialization, padding zeroed."""
import random

import pytest
from rclpy.serialization import deserialize_message, serialize_message

from drive_common.cdr_padding import serialize_zero_padded
from drive_common.telemetry_blocks import BLOCK_PARTS, BlockPacker
from drive_testing.block_probe import message_bits


def _block(block_type, size: int, rng: random.Random):
    packer, block, k = BlockPacker(block_type, size), None, 0
    while block is None:
        records = []
        for _, msg_type in BLOCK_PARTS[block_type]:
            msg = msg_type(step=k)
            for name, kind in msg_type.get_fields_and_field_types().items():
                if kind == 'double':
                    setattr(msg, name, rng.uniform(-1e3, 1e3))
                elif kind == 'string':
                    setattr(msg, name, 'mode' * 5)
            records.append(msg)
        block = packer.append(25_000 * k, *records)
        k += 1
    return block


@pytest.mark.parametrize('block_type', list(BLOCK_PARTS))
@pytest.mark.parametrize('size', [1, 2, 3, 7, 40])
def test_values_kept_and_padding_zeroed(block_type, size):
    block = _block(block_type, size, random.Random(size))
    zeroed = serialize_zero_padded(block)
    assert len(zeroed) == len(serialize_message(block))
    assert message_bits(deserialize_message(zeroed, block_type)) == message_bits(block)
    # Garbage in every padding byte (what a reused rmw buffer leaves) is zeroed again.
    dirty = bytearray(zeroed)
    padding = [i for i in range(4, len(dirty)) if dirty[i] == 0]
    for i in padding:
        dirty[i] = 0xAA
        try:
            same = message_bits(deserialize_message(bytes(dirty), block_type)) == message_bits(block)
        except Exception:  # noqa: BLE001 - a length byte: not padding
            same = False
        if not same:
            dirty[i] = 0
    assert any(dirty[i] == 0xAA for i in padding), 'no padding found'
    assert serialize_zero_padded(deserialize_message(bytes(dirty), block_type)) == zeroed
