"""Small rclpy helpers shared by the recorder, replay and regression nodes."""
from __future__ import annotations

import importlib

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from drive_logger import qos_yaml
from drive_logger.message_definitions import normalize_type_name


class UnknownTypeError(RuntimeError):
    """A message type that is not installed."""


def message_class(type_name: str):
    """The Python class of a message type 'pkg/msg/Type' (or 'pkg/Type')."""
    pkg, _, name = normalize_type_name(type_name).split('/')
    try:
        return getattr(importlib.import_module(f'{pkg}.msg'), name)
    except (ImportError, AttributeError) as exc:
        raise UnknownTypeError(f'unknown message type {type_name!r}: {exc}') from exc


def type_name(msg_class: type) -> str:
    """The type 'pkg/msg/Type' of a generated message class (message_class's inverse)."""
    return f"{msg_class.__module__.split('.')[0]}/msg/{msg_class.__name__}"


def qos_to_dict(qos: QoSProfile) -> dict:
    """rclpy QoSProfile -> metadata.yaml v9 profile."""
    return qos_yaml.profile(
        history=qos_yaml.HISTORY.get(int(qos.history), 'unknown'), depth=qos.depth,
        reliability=qos_yaml.RELIABILITY.get(int(qos.reliability), 'unknown'),
        durability=qos_yaml.DURABILITY.get(int(qos.durability), 'unknown'),
        deadline_ns=qos.deadline.nanoseconds, lifespan_ns=qos.lifespan.nanoseconds,
        liveliness=qos_yaml.LIVELINESS.get(int(qos.liveliness), 'unknown'),
        liveliness_lease_duration_ns=qos.liveliness_lease_duration.nanoseconds,
        avoid_ros_namespace_conventions=qos.avoid_ros_namespace_conventions)


def replay_qos(profiles: list, depth: int = 1000) -> QoSProfile:
    """Publisher QoS for replaying a topic recorded with the given offered profiles: reliable unless
    every one was best effort, transient-local if one was, KEEP_LAST deep enough for a burst."""
    reliable = not profiles or any(p.get('reliability') != 'best_effort' for p in profiles)
    latched = any(p.get('durability') == 'transient_local' for p in profiles)
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=depth,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


def plain(value):
    """A message field or parameter value as plain Python (arrays -> lists of Python numbers)."""
    if isinstance(value, (str, bytes, bool, int, float)) or value is None:
        return value
    return [v.item() if hasattr(v, 'item') else v for v in value]


def fields_of(msg, exclude=('header',)) -> dict:
    """A message's fields as plain Python values (arrays -> lists), header excluded."""
    values = {name: getattr(msg, name) for name in msg.get_fields_and_field_types() if name not in exclude}
    return {name: fields_of(value, ()) if hasattr(value, 'get_fields_and_field_types') else plain(value)
            for name, value in values.items()}
