"""A bag's drive topics as numpy columns: {topic: {field: array}}.

Every message with a header gets ``t`` (s, sim time from the stamp); array fields become
(samples x elements) arrays; numbers are float64, strings object arrays. A per-sample topic
that a block topic of the bag carries (:mod:`drive_logger.block_topics`) is read from every
sample of the block, never mixed with recorded per-sample messages of that name (decimated live
or raw lockstep topics): the columns equal those of a bag of the per-sample topics. Blocks that
skip or repeat steps are refused (BagReadError naming the topic). An export directory of
tables (``drive_logger export BAG --to parquet|csv OUT``) reads the same way.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from drive_logger.bag_reader import BagReader, BagReadError
from drive_logger.block_topics import block_class, block_sources, part_classes, read_blocks

ANALYSED_TOPICS = ('/plant/state', '/dtc/status', '/drive/measurement', '/drive/gate_command',
                   '/pfc/status', '/pfc/measurement', '/pfc/duty_command')


def _arrays(cols: dict[str, list]) -> dict[str, np.ndarray]:
    arrays = {}
    for name, values in cols.items():
        try:
            arrays[name] = np.asarray(values, dtype=float)
        except (TypeError, ValueError):
            arrays[name] = np.asarray(values, dtype=object)
    return arrays


def _recorded_columns(reader: BagReader, topics: list[str]) -> dict[str, dict[str, np.ndarray]]:
    """Columns of per-sample messages as recorded."""
    from drive_common.telemetry_blocks import HOLD_MARK
    rows: dict[str, dict[str, list]] = {t: {} for t in topics}
    for msg, decoded in reader.decoded_messages(topics):
        cols = rows[msg.topic]
        for name in decoded.__slots__:
            value = getattr(decoded, name)
            if name == 'header':
                cols.setdefault('t', []).append(value.stamp.sec + value.stamp.nanosec * 1e-9)
                continue
            if hasattr(value, '__slots__') or name == HOLD_MARK:
                continue
            cols.setdefault(name, []).append(list(value) if isinstance(value, (list, tuple, np.ndarray))
                                             else value)
    return {topic: _arrays(cols) for topic, cols in rows.items()}


def _block_columns(reader: BagReader, wanted: dict[str, tuple[str, int]]) -> dict[str, dict[str, np.ndarray]]:
    """Columns of the wanted per-sample topics {topic: (block topic, part)} from every block sample."""
    from drive_common.telemetry_blocks import block_columns, step_gaps
    blocks = read_blocks(reader, sorted({block for block, _ in wanted.values()}))
    problems = [f'{topic}: {problem}' for topic, msgs in blocks.items() for problem in step_gaps(msgs)]
    if problems:
        raise BagReadError(f'bag {str(reader.path)!r}: blocks skip or repeat steps, not analysed: '
                           + '; '.join(problems[:5]) + (f' (+{len(problems) - 5} more)' if len(problems) > 5 else ''))
    # Each block once: a status block carries three per-sample topics.
    columns_of = {topic: [block_columns(b) for b in msgs] for topic, msgs in blocks.items()}

    def column(block_topic: str, name: str, width: int) -> np.ndarray:
        per_block = columns_of[block_topic]
        return np.concatenate([c[name] for c in per_block]) if per_block else np.zeros(0)
    return {topic: _part_arrays(block_topic, part, column) for topic, (block_topic, part) in wanted.items()}


def _part_arrays(block_topic: str, part: int, column) -> dict[str, np.ndarray]:
    """The columns of one part of a block topic; column(block topic, block field, width) gives a field's values
    (samples, or samples x width), 'time' and 'step' included."""
    from drive_common.telemetry_blocks import layout
    lay = layout(block_class(block_topic))
    msg_type = part_classes(block_topic)[part]
    by_source = {c.source: c for c in lay.columns + lay.per_block if c.part == part}
    arrays = {'t': np.asarray(column(block_topic, 'time', 1), dtype=float)}
    for name in msg_type.get_fields_and_field_types():
        source = by_source.get(name)
        if source is None and name != 'step':
            continue            # the header, and the hold mark
        values = np.asarray(column(block_topic, 'step', 1) if name == 'step'
                            else column(block_topic, source.name, source.width))
        # the dtypes the recorded path gives: float64 numbers, object strings
        arrays[name] = values.astype(object if values.dtype.kind in 'UO' else float)
    return arrays


def _table_columns(directory: Path, topics) -> dict[str, dict[str, np.ndarray]]:
    """Columns of the wanted per-sample topics from the tables of an export directory
    (``drive_logger export --to parquet|csv``), the same columns the bag gives."""
    from drive_logger.block_topics import BLOCK_TOPICS
    from drive_logger.tables import joined, read_table, table_files, table_name
    files = table_files(directory)
    tables: dict[str, dict[str, np.ndarray]] = {}

    def column(block_topic: str, name: str, width: int) -> np.ndarray:
        if block_topic not in tables:
            tables[block_topic] = read_table(files[table_name(block_topic)])
        return joined(tables[block_topic], name, width)
    out = {}
    for block_topic, (_, parts) in BLOCK_TOPICS.items():
        if table_name(block_topic) not in files:
            continue
        for part, topic in enumerate(parts):
            if topic in topics:
                out[topic] = _part_arrays(block_topic, part, column)
    return out


def is_table_export(path) -> bool:
    """True for a directory of exported tables (no bag: no metadata.yaml, no .mcap)."""
    from drive_logger.tables import table_files
    path = Path(path)
    return (path.is_dir() and not (path / 'metadata.yaml').exists() and not any(path.glob('*.mcap'))
            and bool(table_files(path)))


def load_columns(bag: str, salvage: bool = False, topics=ANALYSED_TOPICS,
                 namespace: str = 'auto') -> dict[str, dict[str, np.ndarray]]:
    """Read the given topics of a bag, or of an export directory of tables, into columns
    (missing topics are left out; blocks preferred).

    namespace: the drive's namespace in the bag (BagReader; 'auto': the only one), its topics
    named as without one.
    """
    if is_table_export(bag):
        columns = _table_columns(Path(bag), topics)
        return {t: columns[t] for t in topics if t in columns}
    reader = BagReader(bag, salvage=salvage, namespace=namespace)
    sources = block_sources(reader)
    from_blocks = {t: sources[t] for t in topics if t in sources}
    recorded = [t for t in topics if t in reader.topics and t not in from_blocks]
    columns = _recorded_columns(reader, recorded)
    columns.update(_block_columns(reader, from_blocks) if from_blocks else {})
    return {t: columns[t] for t in topics if t in columns}
