"""Block topics as tables: one row per sample, one column per scalar (the export's naming rule).

Table ``plant_state`` for ``/plant/state_block`` (its status part's topic); columns ``time`` (s
of sim time), ``step``, then every block field by its block name, width 3 split into ``_a``,
``_b``, ``_c`` and width 6 into ``_1`` .. ``_6`` (docs/bags.md). Parquet keeps every bit; CSV
every number exactly, NaN as ``nan``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from drive_logger.block_topics import BLOCK_TOPICS

TABLE_FORMATS = ('parquet', 'csv')
PHASES = ('a', 'b', 'c')


def table_name(block_topic: str) -> str:
    """plant_state for /plant/state_block (its status part's topic, '/' -> '_')."""
    return BLOCK_TOPICS[block_topic][1][0].strip('/').replace('/', '_')


def element_suffixes(width: int) -> tuple[str, ...]:
    """Column suffixes of a field of `width` elements: a/b/c for 3 (phases), 1..width otherwise."""
    if width == 1:
        return ('',)
    if width == 3:
        return tuple('_' + p for p in PHASES)
    return tuple(f'_{i}' for i in range(1, width + 1))


def split_columns(columns: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """block_columns output -> flat table columns (time, step first; 2-D arrays split by the rule)."""
    out = {'time': columns['time'], 'step': columns['step']}
    for name, values in columns.items():
        if name in out:
            continue
        if values.ndim == 2:
            for j, suffix in enumerate(element_suffixes(values.shape[1])):
                out[name + suffix] = values[:, j]
        else:
            out[name] = values
    return out


def joined(table: dict[str, np.ndarray], name: str, width: int) -> np.ndarray:
    """Column `name` of a table, its split columns stacked back (samples x width) when width > 1."""
    if width == 1:
        return table[name]
    return np.stack([table[name + suffix] for suffix in element_suffixes(width)], axis=1)


def table_files(directory: Path) -> dict[str, Path]:
    """{table name: file} of an export directory (parquet preferred over csv)."""
    return {path.stem: path for fmt in reversed(TABLE_FORMATS)
            for path in sorted(Path(directory).glob(f'*.{fmt}'))}


def read_table(path: Path) -> dict[str, np.ndarray]:
    """A table file as {column: numpy array}."""
    if path.suffix == '.parquet':
        import pyarrow.parquet as pq
        table = pq.read_table(path)
    else:
        import pyarrow.csv as pacsv
        # 'nan' is a float NaN, not a missing value (the samples have no missing values)
        table = pacsv.read_csv(path, convert_options=pacsv.ConvertOptions(null_values=[], strings_can_be_null=False))
    return {name: table.column(name).to_numpy(zero_copy_only=False) for name in table.column_names}
