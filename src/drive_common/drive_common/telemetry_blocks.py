"""Sample blocks: N consecutive per-sample messages as one typed message of arrays.

:class:`BlockPacker` fills blocks one sample at a time; :func:`expand` and
:func:`block_columns` are the bit-exact inverse. Layout and rules:
docs/architecture.md "Telemetry: blocks and live topics".
"""
from __future__ import annotations

import array
import threading
from dataclasses import dataclass
from functools import lru_cache
from operator import attrgetter
from typing import Any, Iterator

import numpy as np
from dtc_msgs.msg import (DriveMeasurement, DtcStatus, DtcStatusBlock, DutyCommand, GateCommand,
                          PfcMeasurement, PfcStatus, PfcStatusBlock, PlantState, PlantStateBlock)

from drive_common.telemetry import Decimator, check_block_size, nanoseconds

BLOCK_PARTS: dict[type, tuple[tuple[str, type], ...]] = {
    PlantStateBlock: (('', PlantState),),
    DtcStatusBlock: (('', DtcStatus), ('measurement_', DriveMeasurement),
                     ('command_', GateCommand)),
    PfcStatusBlock: (('', PfcStatus), ('measurement_', PfcMeasurement),
                     ('command_', DutyCommand)),
}
"""(field prefix, per-sample message type) of each block type, in record order."""

# rosidl element type -> (array.array typecode, numpy dtype); bool sequences are lists.
_ELEMENT = {
    'double': ('d', np.float64),
    'int8': ('b', np.int8),
    'uint8': ('B', np.uint8),
    'uint32': ('I', np.uint32),
    'int64': ('q', np.int64),
    'uint64': ('Q', np.uint64),
    'boolean': (None, np.bool_),
}
HOLD_MARK = 'hold_after'
"""The measurements' mark of the last sample before a hold: lockstep protocol, not data, so
blocks (and the columns read from a bag) leave it out and recorded data do not depend on where
a run held."""
LEFT_OUT = ('header', 'step', HOLD_MARK)
"""Per-sample fields without a block array (header and step come from the block's own)."""


@dataclass(frozen=True)
class Column:
    """One block array: per-sample field `source` of part `part` (index into the block's parts)."""

    name: str
    part: int
    source: str
    element: str       # rosidl element type ('double', 'boolean', ...)
    width: int         # elements per sample (1 for scalars)


@dataclass(frozen=True)
class BlockLayout:
    """How a block type's fields map to its per-sample messages."""

    block_type: type
    parts: tuple[tuple[str, type], ...]
    columns: tuple[Column, ...]
    per_block: tuple[Column, ...]    # string fields: one value per block


def _split_type(rosidl_type: str) -> tuple[str, int]:
    """('double', 3) for 'double[3]', ('uint8', 1) for 'uint8'."""
    if rosidl_type.endswith(']'):
        element, width = rosidl_type[:-1].split('[')
        return element, int(width)
    return rosidl_type, 1


@lru_cache(maxsize=None)
def layout(block_type: type) -> BlockLayout:
    """The layout of a block type, derived from its per-sample messages' fields."""
    parts = BLOCK_PARTS[block_type]
    columns, per_block = [], []
    for index, (prefix, msg_type) in enumerate(parts):
        for source, rosidl_type in msg_type.get_fields_and_field_types().items():
            if source in LEFT_OUT:
                continue
            element, width = _split_type(rosidl_type)
            column = Column(prefix + source, index, source, element, width)
            if element == 'string':
                per_block.append(column)
            elif element in _ELEMENT:
                columns.append(column)
            else:
                raise TypeError(f'{msg_type.__name__}.{source}: {rosidl_type} has no block layout')
    return BlockLayout(block_type, parts, tuple(columns), tuple(per_block))


def _tuple_getter(names: list[str]):
    """record -> tuple of its attributes `names` (attrgetter returns a bare value for one name)."""
    if len(names) == 1:
        get = attrgetter(names[0])
        return lambda record: (get(record),)
    return attrgetter(*names)


def stamp_ns(stamp) -> int:
    """A builtin_interfaces/Time as integer ns."""
    return stamp.sec * 1_000_000_000 + stamp.nanosec


class BlockPacker:
    """Collects samples of one block type; a new, filled block every `size` samples.

    ``append(stamp_ns, *records)``: one record per part (:data:`BLOCK_PARTS`), anything with
    the message's field names, all of one ``step``; copied at once; the finished block or None.
    """

    def __init__(self, block_type: type, size: int) -> None:
        self.layout = layout(block_type)
        self.size = check_block_size(size)
        self._getters = tuple(_tuple_getter([c.source for c in self.layout.columns if c.part == p])
                              for p in range(len(self.layout.parts)))
        if any(c.part for c in self.layout.per_block):
            raise TypeError(f'{block_type.__name__}: per-block fields must come from the first part')
        self._block_getter = (_tuple_getter([c.source for c in self.layout.per_block])
                              if self.layout.per_block else None)
        # The spare last row takes a sample that opens a new block while the old is built.
        self._buffer = np.zeros(self.size + 1, dtype=[
            (c.name, _ELEMENT[c.element][1], (c.width,) if c.width > 1 else ())
            for c in self.layout.columns])
        self._stamps = np.zeros(self.size + 1, dtype=np.int64)
        self._count = 0
        self._first_step = self._last_step = self._last_ns = 0
        self._stride = 0
        self._block_values: Any = None

    @property
    def pending(self) -> int:
        """Samples collected for the next block."""
        return self._count

    def append(self, stamp_ns: int, *records) -> Any:
        step = records[0].step
        for record in records[1:]:
            if record.step != step:
                raise ValueError(f'{self.layout.block_type.__name__}: one sample mixes steps '
                                 f'{step} and {record.step}')
        block_values = self._block_getter(records[0]) if self._block_getter else None
        getters = self._getters
        row = (getters[0](records[0]) if len(getters) == 1
               else sum([get(r) for get, r in zip(getters, records)], ()))
        done = None
        n = self._count
        if n and not self._continues(step, stamp_ns, block_values):
            self._buffer[self.size] = row      # a bad value raises before the old block goes
            done = self._build()
            self._buffer[0] = self._buffer[self.size]
            n = 0
        else:
            self._buffer[n] = row
        self._stamps[n] = stamp_ns
        if n == 0:
            self._first_step = step
            self._block_values = block_values
        elif n == 1:
            self._stride = step - self._last_step
        self._last_step, self._last_ns = step, stamp_ns
        self._count = n + 1
        if self._count == self.size:
            # size 1 with a break: the closed block went out on the previous append.
            return self._build()
        return done

    def _continues(self, step: int, stamp_ns: int, block_values) -> bool:
        """Whether the sample extends the open block's regular pattern."""
        if block_values != self._block_values:
            return False
        if stamp_ns <= self._last_ns or stamp_ns - self._stamps[0] >= 1 << 32:
            return False                  # stamps go forward and fit stamp_offset (uint32 ns)
        if self._count == 1:
            return step > self._last_step
        return step - self._last_step == self._stride

    def flush(self) -> Any:
        """The partial block of the samples collected so far, or None if there are none."""
        return self._build() if self._count else None

    def _build(self):
        n, lay = self._count, self.layout
        self._count = 0
        block = lay.block_type()
        stamps = self._stamps[:n]
        block.header.stamp.sec, block.header.stamp.nanosec = divmod(int(stamps[0]), 1_000_000_000)
        block.first_step = self._first_step
        block.count = n
        block.stamp_offset = array.array('I', (stamps - stamps[0]).astype(np.uint32).tobytes())
        if n > 1:
            block.step_stride = self._stride
            block.sample_period = float(stamps[-1] - stamps[0]) / (n - 1) * 1e-9
        for column, value in zip(lay.per_block, self._block_values or ()):
            setattr(block, column.name, value)
        samples = self._buffer[:n]
        for column in lay.columns:
            values = samples[column.name]
            typecode = _ELEMENT[column.element][0]
            if typecode is None:
                setattr(block, column.name, values.ravel().tolist())
            else:       # C order: sample-major
                setattr(block, column.name, array.array(typecode, values.tobytes()))
        return block


class BlockStream:
    """A node's full-rate block topic (packer None: none) and its decimated live topic.

    publish: the block publisher's ``publish``; blocks go out serialized, padding zeroed.
    """

    def __init__(self, block_type: type | None, publish, block_size: int, live_period: float) -> None:
        from drive_common.cdr_padding import serialize_zero_padded   # rclpy: kept off pure imports
        self._serialize, self._publish = serialize_zero_padded, publish
        self._block_type = block_type
        self._lock = threading.Lock()
        self.packer = BlockPacker(block_type, block_size) if block_type is not None else None
        self.live = Decimator(live_period)

    def retune(self, block_size: int, live_period: float) -> None:
        """New telemetry settings: a new block size publishes the open block first."""
        if self.packer is not None and block_size != self.packer.size:
            self.flush()
            with self._lock:
                self.packer = BlockPacker(self._block_type, block_size)
        if nanoseconds(live_period) != self.live.period_ns:
            self.live = Decimator(live_period)

    def append(self, stamp_ns: int, *records) -> bool:
        """Add one sample (publishing a full block); whether the live topic keeps it."""
        if self.packer is not None:
            with self._lock:
                block = self.packer.append(stamp_ns, *records)
            if block is not None:
                self._publish(self._serialize(block))
        return self.live.keep(stamp_ns)

    def flush(self) -> None:
        """Publish the partial block, if any (sim time holds, or the node stops)."""
        if self.packer is None:
            return
        with self._lock:
            block = self.packer.flush()
        if block is not None:
            self._publish(self._serialize(block))


def check_lengths(block, lay: BlockLayout) -> None:
    """ValueError unless every array of block holds count x width elements."""
    count = block.count
    for column in lay.columns:
        if len(getattr(block, column.name)) != count * column.width:
            raise ValueError(f'{type(block).__name__}.{column.name}: '
                             f'{len(getattr(block, column.name))} elements for count {count} '
                             f'x width {column.width}')


def sample_stamps_ns(block) -> np.ndarray:
    """Each sample's header stamp in ns (int64, count elements)."""
    offsets = block.stamp_offset
    if len(offsets) != block.count:
        raise ValueError(f'{type(block).__name__}.stamp_offset: {len(offsets)} elements for count {block.count}')
    return stamp_ns(block.header.stamp) + np.frombuffer(offsets, dtype=np.uint32).astype(np.int64)


def block_columns(block) -> dict[str, np.ndarray]:
    """Every field of a block as count rows (width > 1: (count, width)), plus ``step`` and
    ``time`` (s, as conversions.seconds); ValueError if the arrays do not match count."""
    lay = layout(type(block))
    check_lengths(block, lay)
    count = block.count
    index = np.arange(count, dtype=np.int64)
    ns = sample_stamps_ns(block)
    columns = {
        'step': np.uint64(block.first_step) + np.uint64(block.step_stride) * index.astype(np.uint64),
        'time': (ns // 1_000_000_000).astype(np.float64) + (ns % 1_000_000_000).astype(np.float64) * 1e-9,
    }
    for column in lay.columns:
        data = getattr(block, column.name)
        dtype = _ELEMENT[column.element][1]
        values = (np.frombuffer(data, dtype=dtype) if isinstance(data, array.array)
                  else np.asarray(data, dtype=dtype))
        columns[column.name] = values.reshape(count, column.width) if column.width > 1 else values
    for column in lay.per_block:
        columns[column.name] = np.full(count, getattr(block, column.name))
    return columns


def expand(block, indices=None) -> Iterator[tuple]:
    """The per-sample messages of a block, one tuple per sample in BLOCK_PARTS order, each
    byte-identical to what its node would have published; indices: only these (ascending)."""
    lay = layout(type(block))
    check_lengths(block, lay)
    count = block.count
    rows = list(range(count)) if indices is None else list(indices)
    stamps = sample_stamps_ns(block).tolist()
    per_sample = []
    for column in lay.columns:
        data = getattr(block, column.name)
        w = column.width
        if w == 1:
            per_sample.append([data[i] for i in rows])
        elif column.element == 'boolean':
            per_sample.append([list(data[i * w:(i + 1) * w]) for i in rows])
        else:
            values = np.array(data, dtype=_ELEMENT[column.element][1]).reshape(count, w)
            per_sample.append([values[i] for i in rows])
    constants = [(c.part, c.source, getattr(block, c.name)) for c in lay.per_block]
    targets = [(c.part, c.source) for c in lay.columns]
    frame_id = block.header.frame_id
    for row, i in enumerate(rows):
        msgs = tuple(msg_type() for _, msg_type in lay.parts)
        sec, nanosec = divmod(stamps[i], 1_000_000_000)
        step = block.first_step + i * block.step_stride
        for msg in msgs:
            msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
            msg.header.frame_id = frame_id
            msg.step = step
        for part, source, value in constants:
            setattr(msgs[part], source, value)
        for (part, source), values in zip(targets, per_sample):
            setattr(msgs[part], source, values[row])
        yield msgs


def step_gaps(blocks) -> list[str]:
    """Where consecutive blocks (recorded order) skip or repeat steps; empty when continuous.

    A block continues the previous one one stride after its last step (a one-sample block:
    the last stride known).
    """
    problems: list[str] = []
    last_step, stride = None, 0
    for block in blocks:
        if block.count < 1:
            problems.append(f'empty block at step {block.first_step}')
            continue
        stride = block.step_stride if block.count > 1 else stride
        first = block.first_step
        if last_step is not None:
            if first <= last_step:
                problems.append(f'steps repeated: a block starts at step {first}, '
                                f'the previous one ended at step {last_step}')
            elif stride and first != last_step + stride:
                problems.append(f'steps skipped: step {last_step} is followed by step {first} '
                                f'(stride {stride})')
        last_step = first + (block.count - 1) * block.step_stride
    return problems
