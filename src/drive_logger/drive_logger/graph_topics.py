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
    t.PLANT_STATE_BLOCK: 'dtc_msgs/msg/PlantStateBlock',
    t.DTC_STATUS_BLOCK: 'dtc_msgs/msg/DtcStatusBlock',
    t.PFC_STATUS_BLOCK: 'dtc_msgs/msg/PfcStatusBlock',
    t.CLOCK: 'rosgraph_msgs/msg/Clock',
    t.DIAGNOSTICS: 'diagnostic_msgs/msg/DiagnosticArray',
}
"""Every topic of the drive graph and its type."""

OPTIONAL_TOPIC_TYPES = {
    '/parameter_events': 'rcl_interfaces/msg/ParameterEvent',
    '/rosout': 'rcl_interfaces/msg/Log',
}

LOCKSTEP_TOPICS = [t.DRIVE_MEASUREMENT, t.GATE_COMMAND, t.PFC_MEASUREMENT, t.DUTY_COMMAND]
"""The per-sample lockstep topics: recorded only on request (a second subscriber costs the loop)."""

BLOCK_TOPICS = [t.PLANT_STATE_BLOCK, t.DTC_STATUS_BLOCK, t.PFC_STATUS_BLOCK]
"""Full-rate telemetry: every sample of ground truth, controller status, measurements and commands."""

CANONICAL_AT_SOURCE_TYPES = frozenset(GRAPH_TOPIC_TYPES[name] for name in LOCKSTEP_TOPICS + BLOCK_TOPICS)
"""Types the stack publishes in canonical CDR (zeroed padding, exact length:
drive_common.lockstep_wire, telemetry_blocks); the recorder brings every other
message to that form (drive_common.cdr_padding.canonicalize)."""

DEFAULT_TOPICS = BLOCK_TOPICS + [t.DIAGNOSTICS, t.CLOCK, t.PARAMETER_EVENTS]
"""Default recording: the blocks, /diagnostics, /clock (decimated) and parameter changes; not the
lockstep or live topics, whose samples the blocks hold bit-exact (no subscription on a per-sample publish)."""


def is_paced(type_name: str) -> bool:
    """True for the drive graph's stream types: every dtc_msgs message and /clock's Clock, which their
    publisher sends in sim-time order through the run (a recorder orders its bag by them)."""
    return type_name.startswith('dtc_msgs/') or type_name == 'rosgraph_msgs/msg/Clock'


def known_type(name: str) -> str | None:
    """Type of a drive-graph (or optional) topic, matching relative or absolute names."""
    return next((type_name for table in (GRAPH_TOPIC_TYPES, OPTIONAL_TOPIC_TYPES)
                 for topic, type_name in table.items() if name.lstrip('/') == topic.lstrip('/')), None)


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
