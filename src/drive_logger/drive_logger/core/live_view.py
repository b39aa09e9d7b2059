"""What the live_view node decides without ROS: decimation period, the bounded hand-off, parameter names.

Foxglove parameter names are ``/node.parameter`` (the node's fully qualified name, a dot, the
ROS parameter name, which may itself contain dots).
"""
from __future__ import annotations

import threading
from collections import deque
from typing import Any, Iterable

SEPARATOR = '.'


def check_period(seconds: float) -> float:
    """A decimation period in s; ValueError unless 0 <= seconds <= 10."""
    if not 0.0 <= seconds <= 10.0:
        raise ValueError(f'decimation period {seconds!r} s must be in [0, 10] s')
    return seconds


class Outbox:
    """Bounded FIFO between two threads; a put into a full box drops the oldest item (counted)."""

    def __init__(self, depth: int) -> None:
        if depth < 1:
            raise ValueError(f'queue depth {depth} must be >= 1')
        self.depth = depth
        self.dropped = 0
        self._items: deque = deque()
        self._ready = threading.Condition()
        self._closed = False

    def put(self, item: Any) -> None:
        with self._ready:
            if len(self._items) >= self.depth:
                self._items.popleft()
                self.dropped += 1
            self._items.append(item)
            self._ready.notify()

    def take_all(self, timeout: float) -> list:
        """Everything queued, waiting up to timeout s for the first item ([] on timeout or close)."""
        with self._ready:
            if not self._items and not self._closed:
                self._ready.wait(timeout)
            items = list(self._items)
            self._items.clear()
            return items

    def close(self) -> None:
        with self._ready:
            self._closed = True
            self._ready.notify_all()


def parameter_name(node: str, name: str) -> str:
    """'/dtc_controller', 'torque_reference' -> '/dtc_controller.torque_reference'."""
    return f'{node}{SEPARATOR}{name}'


def split_parameter_name(full: str) -> tuple[str, str]:
    """'/node.param.sub' -> ('/node', 'param.sub'); ValueError naming the expected form."""
    node, sep, name = full.partition(SEPARATOR)
    if not sep or not node.startswith('/') or len(node) < 2 or not name:
        raise ValueError(f'parameter {full!r} is not of the form /node.parameter')
    return node, name


def by_node(full_names: Iterable[str]) -> dict[str, list[str]]:
    """Group '/node.param' names by node (ValueError for a malformed name)."""
    grouped: dict[str, list[str]] = {}
    for full in full_names:
        node, name = split_parameter_name(full)
        grouped.setdefault(node, []).append(name)
    return grouped


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def coerce(value: Any, current: Any) -> Any:
    """A value from the app in the type of the parameter's current value, where lossless: the app
    sends 2.0 as 2, which ROS refuses for a double (array); anything else goes as sent."""
    if isinstance(current, float) and _is_int(value):
        return float(value)
    if (isinstance(current, (list, tuple)) and current and all(isinstance(c, float) for c in current)
            and isinstance(value, list) and all(_is_int(v) or isinstance(v, float) for v in value)):
        return [float(v) for v in value]
    return value


def type_hint(value: Any) -> str | None:
    """Which Foxglove type hint a value needs to keep its ROS type on the wire (None: none)."""
    if isinstance(value, float):
        return 'Float64'
    if isinstance(value, (bytes, bytearray)):
        return 'ByteArray'
    if isinstance(value, (list, tuple)) and value and all(isinstance(v, float) for v in value):
        return 'Float64Array'
    return None
