"""Message <-> core data conversion by field name (the ROS side of the cores).

A core's sample dataclass names its fields after the message's fields, so
one generic copy serves every message type; the header stamp carries the
sample's sim time.
"""
from __future__ import annotations

from dataclasses import fields as dataclass_fields
from functools import lru_cache
from typing import Any

from builtin_interfaces.msg import Time


def time_msg(seconds: float) -> Time:
    """builtin_interfaces/Time of a sim time in seconds (rounded to the nanosecond)."""
    ns = int(round(seconds * 1e9))
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def seconds(stamp: Time) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


@lru_cache(maxsize=None)
def _message_fields(msg_type: type) -> tuple[str, ...]:
    return tuple(name for name in msg_type.get_fields_and_field_types() if name != 'header')


def to_message(msg_type: type, data: Any, time: float | None = None):
    """A msg_type filled from data's attributes of the same names; stamp = time (s)."""
    msg = msg_type()
    for name in _message_fields(msg_type):
        value = getattr(data, name)
        if isinstance(value, tuple):
            value = list(value)
        elif type(value).__module__ == 'numpy' and not hasattr(value, '__len__'):
            value = value.item()   # numpy scalar -> Python (the C converter wants bool, float)
        setattr(msg, name, value)
    if time is not None and hasattr(msg, 'header'):
        msg.header.stamp = time_msg(time)
    return msg


def from_message(msg, data_type: type):
    """An instance of the dataclass data_type from msg's fields of the same names.

    A dataclass field ``time`` is taken from the header stamp; sequences
    become tuples of plain Python values.
    """
    values = {}
    for field in dataclass_fields(data_type):
        if field.name == 'time':
            values['time'] = seconds(msg.header.stamp)
            continue
        value = getattr(msg, field.name)
        if not isinstance(value, (str, bytes, int, float, bool)):
            value = tuple(v.item() if hasattr(v, 'item') else v for v in value)
        values[field.name] = value
    return data_type(**values)
