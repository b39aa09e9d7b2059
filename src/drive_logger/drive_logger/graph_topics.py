"""The drive graph's topics and their types; recorder topic specifications.

Names come from :mod:`drive_common.topics`; relative names resolve against the
recorder's namespace (``/`` by default). A topic specification is ``name`` for
a topic of the drive graph (or one whose type is discovered on the graph) or
``name:pkg/msg/Type``.
"""
from __future__ import annotations

import time
from pathlib import Path

from drive_common import topics as t

GRAPH_TOPIC_TYPES = {
    t.DRIVE_MEASUREMENT: 'dtc_msgs/msg/DriveMeasurement',
    t.GATE_COMMAND: 'dtc_msgs/msg/GateCommand',
    t.PFC_MEASUREMENT: 'dtc_msgs/msg/PfcMeasurement',
    t.DUTY_COMMAND: 'dtc_msgs/msg/DutyCommand',
    t.PLANT_STATE: 'dtc_msgs/msg/PlantState',
    t.DTC_STATUS: 'dtc_msgs/msg/DtcStatus',
    t.PFC_STATUS: 'dtc_msgs/msg/PfcStatus',
    t.CLOCK: 'rosgraph_msgs/msg/Clock',
    t.DIAGNOSTICS: 'diagnostic_msgs/msg/DiagnosticArray',
}
"""Default recording: every topic of the drive graph."""

OPTIONAL_TOPIC_TYPES = {
    '/parameter_events': 'rcl_interfaces/msg/ParameterEvent',
    '/rosout': 'rcl_interfaces/msg/Log',
}

DEFAULT_TOPICS = list(GRAPH_TOPIC_TYPES)


def known_type(name: str) -> str | None:
    """Type of a drive-graph (or optional) topic, matching relative or absolute names."""
    for table in (GRAPH_TOPIC_TYPES, OPTIONAL_TOPIC_TYPES):
        for topic, type_name in table.items():
            if name == topic or name.lstrip('/') == topic.lstrip('/'):
                return type_name
    return None


def parse_topic_spec(spec: str) -> tuple[str, str | None]:
    """'name' or 'name:pkg/msg/Type' -> (name, type or None if unknown)."""
    spec = spec.strip()
    if not spec:
        raise ValueError('empty topic name')
    name, sep, type_name = spec.partition(':')
    if sep and not type_name:
        raise ValueError(f'topic spec {spec!r} has an empty type')
    return name, (type_name or known_type(name))


def default_output_dir(root: str | Path = 'bags') -> Path:
    """bags/<YYYYmmdd-HHMMSS> (local time), as ``ros2 bag record`` names its bags."""
    return Path(root) / time.strftime('%Y%m%d-%H%M%S')
