"""Canonical CDR: a message's serialization with zeroed padding and its exact length, so the
recorded bytes depend on the values only (docs/architecture.md "Time and lockstep")."""
from __future__ import annotations

from rclpy.serialization import deserialize_message, serialize_message

ENCAPSULATION_HEADER = 4   # bytes; alignment counts from its end
PRIMITIVE_SIZES = {'boolean': 1, 'octet': 1, 'char': 1, 'int8': 1, 'uint8': 1, 'int16': 2, 'uint16': 2,
                   'int32': 4, 'uint32': 4, 'float': 4, 'int64': 8, 'uint64': 8, 'double': 8}
STRUCT_CODES = {'boolean': '?', 'octet': 'B', 'char': 'B', 'int8': 'b', 'uint8': 'B', 'int16': 'h',
                'uint16': 'H', 'int32': 'i', 'uint32': 'I', 'int64': 'q', 'uint64': 'Q', 'float': 'f',
                'double': 'd'}
"""rosidl primitive -> struct (and numpy dtype) code of its CDR encoding."""


def padding(body_offset: int, size: int) -> int:
    """Bytes of padding before an item of `size` at `body_offset` (after the encapsulation header)."""
    return -body_offset % size


def _align(data: bytearray, offset: int, size: int) -> int:
    """Zero the padding before a size-aligned item at offset; the item's offset."""
    aligned = offset + padding(offset - ENCAPSULATION_HEADER, size)
    data[offset:aligned] = bytes(aligned - offset)
    return aligned


def _element(kind: str) -> tuple[str, str]:
    """('sequence' | 'array' | 'single', element kind without bounds) of a rosidl field kind."""
    if kind.startswith('sequence<'):
        return 'sequence', kind[len('sequence<'):-1].split(',')[0].strip()
    if kind.endswith(']'):
        return 'array', kind[:kind.index('[')]
    return 'single', kind


def _walk_item(kind: str, value, data: bytearray, offset: int, where: str) -> int:
    """Zero the padding of one value of a non-array kind; the offset after it."""
    if kind in PRIMITIVE_SIZES:
        size = PRIMITIVE_SIZES[kind]
        return _align(data, offset, size) + size
    if kind == 'string' or kind.startswith('string<'):
        return _align(data, offset, 4) + 4 + len(value.encode()) + 1
    if hasattr(value, 'get_fields_and_field_types'):
        return _walk(value, data, offset)
    raise TypeError(f'{where}: {kind} is not handled')


def _walk(msg, data: bytearray, offset: int) -> int:
    for name, kind in msg.get_fields_and_field_types().items():
        value = getattr(msg, name)
        where = f'{type(msg).__name__}.{name}'
        shape, element = _element(kind)
        if shape == 'sequence':
            offset = _align(data, offset, 4) + 4
        if shape == 'single':
            offset = _walk_item(kind, value, data, offset, where)
        elif element in PRIMITIVE_SIZES:
            if len(value):           # an empty sequence's elements are not aligned
                size = PRIMITIVE_SIZES[element]
                offset = _align(data, offset, size) + size * len(value)
        else:
            for item in value:
                offset = _walk_item(element, item, data, offset, where)
    return offset


def canonical_bytes(msg, data: bytes) -> bytes:
    """data (a CDR serialization of msg) with every padding byte zeroed and nothing after the last field."""
    zeroed = bytearray(data)
    end = _walk(msg, zeroed, ENCAPSULATION_HEADER)
    if end > len(zeroed):
        raise ValueError(f'{type(msg).__name__}: fields end at byte {end} of {len(zeroed)}')
    return bytes(zeroed[:end])


def serialize_zero_padded(msg) -> bytes:
    """msg serialized as rclpy does, in canonical CDR (padding zeroed, exact length)."""
    return canonical_bytes(msg, serialize_message(msg))


def canonicalize(data: bytes, msg_class) -> bytes:
    """Serialized bytes of a message of msg_class in canonical CDR (the values' bits kept)."""
    return canonical_bytes(deserialize_message(data, msg_class), data)
