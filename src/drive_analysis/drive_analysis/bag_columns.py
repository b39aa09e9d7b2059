"""A bag's drive topics as numpy columns (no ROS): {topic: {field: array}}.

Every message with a header gets ``t`` (s, sim time from the stamp); array
fields become 2-D arrays (samples x elements).
"""
from __future__ import annotations

import numpy as np

from drive_logger.bag_reader import BagReader

ANALYSED_TOPICS = ('/plant/state', '/dtc/status', '/drive/measurement', '/drive/gate_command',
                   '/pfc/status', '/pfc/measurement', '/pfc/duty_command')


def _plain(value):
    if isinstance(value, (list, tuple, np.ndarray)):
        return list(value)
    return value


def load_columns(bag: str, salvage: bool = False, topics=ANALYSED_TOPICS) -> dict[str, dict[str, np.ndarray]]:
    """Read the given topics of a bag into columns (missing topics are left out)."""
    reader = BagReader(bag, salvage=salvage)
    present = [t for t in topics if t in reader.topics]
    rows: dict[str, dict[str, list]] = {t: {} for t in present}
    for msg, decoded in reader.decoded_messages(present):
        cols = rows[msg.topic]
        for name in decoded.__slots__:
            value = getattr(decoded, name)
            if name == 'header':
                cols.setdefault('t', []).append(value.stamp.sec + value.stamp.nanosec * 1e-9)
                continue
            if hasattr(value, '__slots__'):
                continue
            cols.setdefault(name, []).append(_plain(value))
    out = {}
    for topic, cols in rows.items():
        arrays = {}
        for name, values in cols.items():
            try:
                arrays[name] = np.asarray(values, dtype=float)
            except (TypeError, ValueError):
                arrays[name] = np.asarray(values, dtype=object)
        out[topic] = arrays
    return out
