"""Export a bag for viewers and tables: ``ros2 run drive_logger export BAG --to mcap|parquet|csv OUT``.

``--to mcap``: a viewer bag where every sample of the block topics is its own message
(:mod:`drive_logger.sample_topics`), ``/clock``, ``/parameter_events`` and ``/diagnostics``
copied; ``--to parquet|csv``: one table per block topic (:mod:`drive_logger.tables`). Streams
block by block in bounded memory. Exit 0 done, 2 bad input (docs/bags.md).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from rclpy.serialization import deserialize_message

from drive_common.telemetry_blocks import block_columns
from drive_logger.bag_reader import BagReader, BagReadError
from drive_logger.bag_writer import BagWriteError, BagWriter
from drive_logger.block_topics import BLOCK_TOPICS, block_class, block_sources
from drive_logger.sample_topics import ALL_PARTS, SampleTopics, write_canonical
from drive_logger.tables import TABLE_FORMATS, split_columns, table_name
from drive_common.cli_output import quiet_on_closed_pipe

FORMATS = ('mcap',) + TABLE_FORMATS
ROWS_PER_GROUP = 1 << 14
"""Rows buffered per table before they are written (one Parquet row group)."""


class ExportError(RuntimeError):
    """Bad export input (the message names it)."""


def _ns(seconds: float | None) -> int | None:
    return None if seconds is None else int(round(seconds * 1e9))


def _progress(total: int | None, quiet: bool, what: str):
    from tqdm import tqdm
    return tqdm(total=total, unit='msg', desc=what, disable=quiet or not sys.stderr.isatty())


def export_mcap(reader: BagReader, out: Path, topics=None, start=None, end=None, every: int = 1,
                quiet: bool = True) -> BagWriter:
    """Write the full-rate viewer bag of reader into the new directory out; return its (closed) writer."""
    if len(reader.files) != 1:
        raise ExportError(f'bag {str(reader.path)!r} has {len(reader.files)} data files; export takes one')
    samples = SampleTopics(0.0, ALL_PARTS, every, _ns(start), _ns(end))
    total = sum(t.message_count or 0 for t in reader.topics.values()) or None
    writer = BagWriter(out, compression='zstd', log_time=reader.log_time_source)
    with _progress(total, quiet, 'export') as bar:
        write_canonical(reader.files[0], writer, samples, topics=topics, keep_blocks=False,
                        replace_samples=True, start_ns=_ns(start), end_ns=_ns(end), progress=bar.update)
    writer.close()
    return writer


class _TableWriter:
    """Streams rows of one table into a Parquet or CSV file."""

    def __init__(self, path: Path, fmt: str) -> None:
        self.path, self.fmt = path, fmt
        self._writer = None
        self._rows: list[dict] = []
        self._buffered = 0
        self.rows = 0

    def append(self, columns: dict) -> None:
        self._rows.append(columns)
        self._buffered += len(columns['time'])
        if self._buffered >= ROWS_PER_GROUP:
            self.flush()

    def flush(self) -> None:
        import pyarrow as pa
        if not self._rows:
            return
        names = list(self._rows[0])
        table = pa.table({n: np.concatenate([r[n] for r in self._rows]) for n in names})
        if self._writer is None:
            if self.fmt == 'parquet':
                import pyarrow.parquet as pq
                self._writer = pq.ParquetWriter(self.path, table.schema, compression='zstd')
            else:
                import pyarrow.csv as pacsv
                self._writer = pacsv.CSVWriter(self.path, table.schema)
        self._writer.write_table(table)
        self.rows += table.num_rows
        self._rows, self._buffered = [], 0

    def close(self) -> None:
        self.flush()
        if self._writer is not None:
            self._writer.close()


def export_tables(reader: BagReader, out: Path, fmt: str, topics=None, start=None, end=None,
                  every: int = 1, quiet: bool = True) -> dict[str, Path]:
    """One table per block topic into the new directory out; {table name: file}."""
    present = sorted({block for block, _ in block_sources(reader).values()})
    if topics is not None:
        wanted = set(topics)
        present = [b for b in present if b in wanted or wanted & set(BLOCK_TOPICS[b][1])]
    if not present:
        raise ExportError(f'bag {str(reader.path)!r} holds no block topic to export'
                          + (f' among {sorted(topics)}' if topics else ''))
    out.mkdir(parents=True)
    writers = {b: _TableWriter(out / f'{table_name(b)}.{fmt}', fmt) for b in present}
    classes = {b: block_class(b) for b in present}
    kept = dict.fromkeys(present, 0)
    lo, hi = _ns(start), _ns(end)
    total = sum(reader.topics[b].message_count or 0 for b in present) or None
    with _progress(total, quiet, 'export') as bar:
        for msg in reader.messages(present):
            bar.update(1)
            block = deserialize_message(msg.data, classes[msg.topic])
            if not block.count:
                continue
            columns = block_columns(block)
            stamps = np.round(columns['time'] * 1e9) if lo is not None or hi is not None else None
            mask = np.ones(block.count, dtype=bool)
            if lo is not None:
                mask &= stamps >= lo
            if hi is not None:
                mask &= stamps <= hi
            index = kept[msg.topic] + np.cumsum(mask) - 1     # rank among the kept samples
            kept[msg.topic] += int(mask.sum())
            mask &= index % every == 0
            if mask.any():
                writers[msg.topic].append({k: v[mask] for k, v in split_columns(columns).items()})
    for writer in writers.values():
        writer.close()
    return {table_name(b): w.path for b, w in writers.items()}


@quiet_on_closed_pipe
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog='ros2 run drive_logger export', description=__doc__.split('\n')[0])
    parser.add_argument('bag', help='bag directory (or .mcap file)')
    parser.add_argument('--to', required=True, choices=FORMATS, help='output format')
    parser.add_argument('out', help='output directory to create')
    parser.add_argument('--topics', nargs='+', help='only these topics (per-sample or block names)')
    parser.add_argument('--start', type=float, help='first sim time to keep (s)')
    parser.add_argument('--end', type=float, help='last sim time to keep (s)')
    parser.add_argument('--every', type=int, default=1, help='keep every N-th sample (default 1)')
    parser.add_argument('--quiet', action='store_true', help='no progress bar')
    args = parser.parse_args(argv)
    try:
        if args.every < 1:
            raise ExportError(f'--every must be >= 1, got {args.every}')
        if args.start is not None and args.end is not None and args.end < args.start:
            raise ExportError(f'--end {args.end} is before --start {args.start}')
        out = Path(args.out)
        if out.exists():
            raise ExportError(f'output {str(out)!r} already exists: refusing to overwrite')
        reader = BagReader(args.bag)
        options = dict(topics=args.topics, start=args.start, end=args.end, every=args.every, quiet=args.quiet)
        if args.to == 'mcap':
            writer = export_mcap(reader, out, **options)
            print(f'exported {writer.message_count} messages to {out}')
        else:
            files = export_tables(reader, out, args.to, **options)
            print(f'exported {len(files)} table(s) to {out}: {", ".join(sorted(files))}')
    except (ExportError, BagReadError, BagWriteError) as exc:
        print(f'export: {exc}', file=sys.stderr)
        return 2
    return 0


if __name__ == '__main__':
    sys.exit(main())
