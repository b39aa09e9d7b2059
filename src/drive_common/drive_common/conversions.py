"""Message <-> core sample conversion by field name; the header stamp carries the sim time."""
from __future__ import annotations

from dataclasses import fields as dataclass_fields
from functools import lru_cache
from typing import Any

from builtin_interfaces.msg import Time


def sec_nanosec(seconds: float) -> tuple[int, int]:
    """(sec, nanosec) of a sim time in seconds, rounded to the nanosecond."""
    return divmod(int(round(seconds * 1e9)), 1_000_000_000)


def time_msg(seconds: float) -> Time:
    """builtin_interfaces/Time of a sim time in seconds (rounded to the nanosecond)."""
    sec, nanosec = sec_nanosec(seconds)
    return Time(sec=sec, nanosec=nanosec)


def seconds(stamp: Time) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


@lru_cache(maxsize=None)
def _message_fields(msg_type: type) -> tuple[str, ...]:
    return tuple(name for name in msg_type.get_fields_and_field_types() if name != 'header')


def _plain(value):
    """A value the generated message setters accept: tuples become lists, numpy scalars Python."""
    kind = type(value)
    if kind is float or kind is int or kind is bool:
        return value
    if kind is tuple:
        return list(value)
    if kind.__module__ == 'numpy' and not hasattr(value, '__len__'):
        return value.item()   # numpy scalar -> Python (the C converter wants bool, float)
    return value


class ReusedMessage:
    """One message instance, refilled from a core sample before every publish (cheaper than a
    new one); do not keep the returned message: the next ``fill`` overwrites it."""

    def __init__(self, msg_type: type) -> None:
        self.msg = msg_type()
        self._names = _message_fields(msg_type)

    def fill(self, data: Any, time: float | None = None, stamp: Time | None = None):
        """The message with data's fields; header stamp = time (s) or the given stamp."""
        msg = self.msg
        for name in self._names:
            setattr(msg, name, _plain(getattr(data, name)))
        if stamp is not None:
            msg.header.stamp = stamp
        elif time is not None:
            header_stamp = msg.header.stamp
            header_stamp.sec, header_stamp.nanosec = sec_nanosec(time)
        return msg


@lru_cache(maxsize=None)
def _sample_fields(data_type: type) -> tuple[str, ...]:
    return tuple(field.name for field in dataclass_fields(data_type))


def from_message(msg, data_type: type):
    """An instance of the dataclass data_type from msg's fields of the same names (``time``:
    the header stamp; sequences become tuples of plain Python values)."""
    values = {}
    for name in _sample_fields(data_type):
        if name == 'time':
            values['time'] = seconds(msg.header.stamp)
            continue
        value = getattr(msg, name)
        kind = type(value)
        if not (kind is float or kind is int or kind is bool or kind is str or kind is bytes):
            value = tuple(value.tolist() if hasattr(value, 'tolist') else value)
        values[name] = value
    return data_type(**values)
