"""The lockstep messages as CDR bytes, straight from and into the core samples.

A typed rclpy take or publish costs several times a raw one, so the lockstep nodes convert
bytes <-> sample dataclass here with one :class:`struct.Struct` per message type: rclpy's
serialization with zeroed padding. Qualifies: a ``std_msgs/Header`` then fixed-size fields.
"""
from __future__ import annotations

import struct
from dataclasses import fields as dataclass_fields
from functools import lru_cache
from typing import Any

from drive_common.cdr_padding import ENCAPSULATION_HEADER, PRIMITIVE_SIZES, STRUCT_CODES, padding

ENCAPSULATION = b'\x00\x01\x00\x00'     # CDR, little endian


@lru_cache(maxsize=None)
def _fields(msg_type: type) -> tuple[tuple[str, str, int], ...]:
    """(name, primitive, count) of the fields after the header; TypeError if not fixed-size."""
    items = list(msg_type.get_fields_and_field_types().items())
    if not items or items[0] != ('header', 'std_msgs/Header'):
        raise TypeError(f'{msg_type.__name__}: the first field must be std_msgs/Header header')
    out = []
    for name, kind in items[1:]:
        element, count = kind, 1
        if kind.endswith(']') and '[' in kind and not kind.endswith('[]'):
            element, count = kind[:-1].split('[')
            count = int(count)
        if element not in STRUCT_CODES:
            raise TypeError(f'{msg_type.__name__}.{name}: {kind} has no fixed CDR size')
        out.append((name, element, count))
    return tuple(out)


def _tail_format(fields, offset: int) -> tuple[str, int]:
    """struct format ('<'-less) of the fields from body offset `offset`; the end offset."""
    parts = []
    for _, element, count in fields:
        code, size = STRUCT_CODES[element], PRIMITIVE_SIZES[element]
        pad = padding(offset, size)
        if pad:
            parts.append(f'{pad}x')
        parts.append(f'{count}{code}' if count > 1 else code)
        offset += pad + size * count
    return ''.join(parts), offset


class LockstepWire:
    """CDR bytes <-> core sample_type (same field names; ``time``: the header stamp in s) for
    msg_type; frame_id: the one :meth:`encode` writes (any is read)."""

    def __init__(self, msg_type: type, sample_type: type, frame_id: str = '') -> None:
        self.msg_type, self.sample_type = msg_type, sample_type
        self._fields = _fields(msg_type)
        names = [f.name for f in dataclass_fields(sample_type)]
        missing = [n for n in names if n != 'time' and n not in {f[0] for f in self._fields}]
        if missing:
            raise TypeError(f'{sample_type.__name__}: no {msg_type.__name__} field for {missing}')
        # Sample fields -> (index into the flat unpacked values, count); None: the stamp in s.
        spans, index = {}, 0
        for name, _, count in self._fields:
            spans[name] = (index, count)
            index += count
        self._spans = [None if n == 'time' else spans[n] for n in names]
        # Encoding: the fixed frame_id gives one struct for the whole message.
        frame = frame_id.encode() + b'\x00'
        tail, _ = _tail_format(self._fields, 8 + 4 + len(frame))
        self._frame = frame
        self._encoder = struct.Struct(f'<iII{len(frame)}s{tail}')
        self._tails: dict[int, struct.Struct] = {}   # body offset % 8 after a frame_id -> fields

    def _tail(self, residue: int) -> struct.Struct:
        """The struct of the fields after a frame_id ending at body offset = residue (mod 8)."""
        tail = self._tails.get(residue)
        if tail is None:
            tail = self._tails[residue] = struct.Struct('<' + _tail_format(self._fields, residue)[0])
        return tail

    def encode(self, sample, sec: int, nanosec: int) -> bytes:
        """The serialized message of sample (field values by name) stamped (sec, nanosec)."""
        values = []
        for name, _, count in self._fields:
            value = getattr(sample, name)
            if count > 1:
                if len(value) != count:
                    raise ValueError(f'{self.msg_type.__name__}.{name}: {len(value)} values, '
                                     f'expected {count}')
                values.extend(value)
            else:
                values.append(value)
        return ENCAPSULATION + self._encoder.pack(sec, nanosec, len(self._frame), self._frame,
                                                  *values)

    def decode(self, data: bytes) -> tuple[Any, int, int]:
        """(sample, sec, nanosec) of a serialized message; ValueError names a malformed one."""
        if len(data) < 16 or data[:2] != ENCAPSULATION[:2]:
            raise ValueError(f'{self.msg_type.__name__}: not a little-endian CDR message '
                             f'({len(data)} bytes)')
        sec, nanosec, frame_length = struct.unpack_from('<iII', data, ENCAPSULATION_HEADER)
        offset = 12 + frame_length                     # body offset after the frame_id
        tail = self._tail(offset % 8)
        start = ENCAPSULATION_HEADER + offset
        if len(data) < start + tail.size:
            raise ValueError(f'{self.msg_type.__name__}: {len(data)} bytes, the fields need '
                             f'{start + tail.size}')
        flat = tail.unpack_from(data, start)
        args = [sec + nanosec * 1e-9 if span is None else
                flat[span[0]] if span[1] == 1 else flat[span[0]:span[0] + span[1]]
                for span in self._spans]
        return self.sample_type(*args), sec, nanosec
