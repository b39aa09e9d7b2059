"""QoS profiles in the rosbag2 (metadata version 9) form, without rclpy.

A profile is one item of ``offered_qos_profiles`` in metadata.yaml; the MCAP channel carries the
same list as a YAML string. Durations are ``{sec, nsec}``; "infinite" is rmw's 2**63-1 ns.
"""
from __future__ import annotations

from typing import Any

import yaml

INFINITE_NS = 9223372036854775807
HISTORY = {0: 'system_default', 1: 'keep_last', 2: 'keep_all', 3: 'unknown'}
RELIABILITY = {0: 'system_default', 1: 'reliable', 2: 'best_effort', 3: 'unknown', 4: 'best_available'}
DURABILITY = {0: 'system_default', 1: 'transient_local', 2: 'volatile', 3: 'unknown', 4: 'best_available'}
LIVELINESS = {0: 'system_default', 1: 'automatic', 3: 'manual_by_topic', 4: 'unknown', 5: 'best_available'}


def duration(nanoseconds: int) -> dict[str, int]:
    """{sec, nsec} of a duration in ns; 0 or anything >= 2**63-1 ns maps as rmw prints it."""
    nanoseconds = min(int(nanoseconds), INFINITE_NS)
    return {'sec': nanoseconds // 1_000_000_000, 'nsec': nanoseconds % 1_000_000_000}


def profile(history: str = 'keep_last', depth: int = 8, reliability: str = 'reliable',
            durability: str = 'volatile', deadline_ns: int = INFINITE_NS,
            lifespan_ns: int = INFINITE_NS, liveliness: str = 'automatic',
            liveliness_lease_duration_ns: int = INFINITE_NS,
            avoid_ros_namespace_conventions: bool = False) -> dict[str, Any]:
    """One profile as a metadata.yaml v9 item (defaults: the lockstep QoS)."""
    return {
        'history': history,
        'depth': int(depth),
        'reliability': reliability,
        'durability': durability,
        'deadline': duration(deadline_ns),
        'lifespan': duration(lifespan_ns),
        'liveliness': liveliness,
        'liveliness_lease_duration': duration(liveliness_lease_duration_ns),
        'avoid_ros_namespace_conventions': bool(avoid_ros_namespace_conventions),
    }


def dump(profiles: list[dict[str, Any]]) -> str:
    """The channel-metadata YAML string of a profile list ('' for none)."""
    if not profiles:
        return ''
    return yaml.safe_dump(profiles, default_flow_style=False, sort_keys=False).strip()


def load(text_or_list: str | list | None) -> list[dict[str, Any]]:
    """Profiles from metadata.yaml (a list) or channel metadata (a YAML string)."""
    if not text_or_list:
        return []
    if isinstance(text_or_list, str):
        return list(yaml.safe_load(text_or_list) or [])
    return list(text_or_list)
