"""Serialized messages with zeroed CDR alignment padding (byte-identical bags).

rmw_fastrtps serializes a published message into a reused payload buffer
and Fast CDR skips the alignment padding without writing it, so the padding
bytes of a message hold whatever an earlier message left there. The
telemetry blocks are sequences of float64 after 4-byte sequence lengths, so
every block has such padding: two runs of one scenario would record the
same values in different bytes. :func:`serialize_zero_padded` serializes a
message (``rclpy.serialization``) and zeroes every padding byte, walking the
fields with the CDR (XCDR1) alignment rules (each primitive aligned to its
size from the end of the 4-byte encapsulation header; strings and sequence
lengths to 4); publishing these bytes (``Publisher.publish`` takes
serialized bytes) makes the recorded data a function of the values only.
"""
from __future__ import annotations

from rclpy.serialization import serialize_message

ENCAPSULATION_HEADER = 4   # bytes; alignment counts from its end
PRIMITIVE_SIZES = {'boolean': 1, 'octet': 1, 'char': 1, 'int8': 1, 'uint8': 1, 'int16': 2, 'uint16': 2,
                   'int32': 4, 'uint32': 4, 'float': 4, 'int64': 8, 'uint64': 8, 'double': 8}


def padding(body_offset: int, size: int) -> int:
    """Bytes of padding before an item of `size` at `body_offset` (counted from the
    encapsulation header's end)."""
    return -body_offset % size


def _align(data: bytearray, offset: int, size: int) -> int:
    """Zero the padding before a size-aligned item at offset; the item's offset."""
    aligned = offset + padding(offset - ENCAPSULATION_HEADER, size)
    data[offset:aligned] = bytes(aligned - offset)
    return aligned


def _walk(msg, data: bytearray, offset: int) -> int:
    for name, kind in msg.get_fields_and_field_types().items():
        value = getattr(msg, name)
        if kind.startswith('sequence<'):
            element = kind[len('sequence<'):-1]
            if element not in PRIMITIVE_SIZES:
                raise TypeError(f'{type(msg).__name__}.{name}: {kind} is not handled')
            offset = _align(data, offset, 4) + 4
            if len(value):
                size = PRIMITIVE_SIZES[element]
                offset = _align(data, offset, size) + size * len(value)
        elif kind == 'string':
            offset = _align(data, offset, 4) + 4 + len(value.encode()) + 1
        elif kind in PRIMITIVE_SIZES:
            offset = _align(data, offset, PRIMITIVE_SIZES[kind]) + PRIMITIVE_SIZES[kind]
        elif kind.endswith(']') and kind.split('[')[0] in PRIMITIVE_SIZES:
            size = PRIMITIVE_SIZES[kind.split('[')[0]]
            offset = _align(data, offset, size) + size * len(value)
        elif hasattr(value, 'get_fields_and_field_types'):
            offset = _walk(value, data, offset)
        else:
            raise TypeError(f'{type(msg).__name__}.{name}: {kind} is not handled')
    return offset


def serialize_zero_padded(msg) -> bytes:
    """msg serialized as rclpy does, with every alignment padding byte set to zero."""
    data = bytearray(serialize_message(msg))
    end = _walk(msg, data, ENCAPSULATION_HEADER)
    if not 0 <= len(data) - end < 4:
        raise ValueError(f'{type(msg).__name__}: fields end at byte {end} of {len(data)}')
    data[end:] = bytes(len(data) - end)      # trailing padding to a multiple of 4
    return bytes(data)
