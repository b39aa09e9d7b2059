"""Per-sample messages derived from a bag's telemetry blocks, and bag files in one total order.

:class:`SampleTopics` turns a block into the per-sample messages of its parts, bit-exact in
canonical CDR at their sample's time, decimated by sim time (the recorder's viewer topics).
:class:`CanonicalWriter` (a recording as it comes) and :func:`write_canonical` (a complete
file: the exporter) write messages sorted by log time, topic and order within the topic, so
two recordings of one scenario are byte-identical files.
"""
from __future__ import annotations

import heapq
import struct
from pathlib import Path
from typing import Callable, Iterable, Iterator

import numpy as np
from mcap.reader import make_reader
from rclpy.serialization import deserialize_message, serialize_message

from drive_common.cdr_padding import ENCAPSULATION_HEADER, PRIMITIVE_SIZES, STRUCT_CODES, canonical_bytes, padding
from drive_common.telemetry import Decimator
from drive_common.telemetry_blocks import block_columns, check_lengths, expand, layout, sample_stamps_ns
from drive_logger import qos_yaml, ros_types
from drive_logger.bag_writer import BagWriteError, BagWriter, TopicRecord
from drive_logger.block_topics import BLOCK_TOPICS, block_class, part_classes, split_namespace
from drive_logger.message_definitions import TypeDefinition, type_definition

STATUS_PARTS = (0,)
"""Parts whose per-sample topics the recorder adds for viewers (the status: plant/state, dtc/status, pfc/status)."""
ALL_PARTS = (0, 1, 2)
"""Every part: status, measurement, command (the full-rate export)."""


class SampleTopics:
    """Per-sample messages of block messages: period s of sim time between kept samples (0: all),
    parts (BLOCK_PARTS indexes) to derive, every N-th kept sample per block topic, only samples
    stamped in [start_ns, end_ns] (None: no bound)."""

    def __init__(self, period: float = 0.0, parts: Iterable[int] = STATUS_PARTS, every: int = 1,
                 start_ns: int | None = None, end_ns: int | None = None) -> None:
        if every < 1:
            raise ValueError(f'every must be >= 1, got {every}')
        self.period = period
        self.parts = tuple(parts)
        self.every = every
        self.start_ns, self.end_ns = start_ns, end_ns
        self._decimators: dict[str, Decimator] = {}
        self._counters: dict[str, int] = {}
        self._templates: dict = {}      # sample_cdr's templates, per layout

    def topics_for(self, block_topics: Iterable[str]) -> dict[str, tuple[str, str, int]]:
        """{per-sample topic: (type name, block topic, part)} derived from the given block topics."""
        out = {}
        for block_topic in block_topics:
            split = split_namespace(block_topic)     # a drive's namespace stays on its topics
            if split is None:
                continue
            namespace, base = split
            classes = part_classes(base)
            for part in self.parts:
                if part >= len(classes):     # the plant's block has one part
                    continue
                type_name = ros_types.type_name(classes[part])
                out[namespace + BLOCK_TOPICS[base][1][part]] = (type_name, block_topic, part)
        return out

    def derive(self, block_topic: str, data: bytes, log_time: int, publish_time: int,
               wanted: set[str] | None = None) -> Iterator[tuple[str, int, int, bytes]]:
        """(topic, log time, publish time, canonical CDR) of the kept samples of one block message."""
        namespace, base = split_namespace(block_topic)
        block = deserialize_message(data, block_class(base))
        if not block.count:
            return
        stamps = sample_stamps_ns(block).tolist()
        decimator = self._decimators.get(block_topic)
        if decimator is None:
            decimator = self._decimators[block_topic] = Decimator(self.period)
        kept = []
        for i, stamp in enumerate(stamps):
            if ((self.start_ns is not None and stamp < self.start_ns)
                    or (self.end_ns is not None and stamp > self.end_ns) or not decimator.keep(stamp)):
                continue
            counter = self._counters.get(block_topic, 0)
            self._counters[block_topic] = counter + 1
            if counter % self.every == 0:
                kept.append(i)
        if not kept:
            return
        names = [namespace + name for name in BLOCK_TOPICS[base][1]]
        parts = [(p, names[p]) for p in self.parts if p < len(names) and (wanted is None or names[p] in wanted)]
        rows = {part: sample_cdr(block, part, kept, self._templates) for part, _ in parts}
        for j, i in enumerate(kept):
            offset = stamps[i] - stamps[0]
            for part, topic in parts:
                yield topic, log_time + offset, publish_time + offset, rows[part][j]


def _field_offsets(msg) -> tuple[dict[str, int], int]:
    """({field: byte offset after the encapsulation header}, end) of msg's little-endian CDR
    (a std_msgs/Header, then primitives, fixed arrays of primitives and strings)."""
    offsets, pos = {}, 0
    for name, kind in type(msg).get_fields_and_field_types().items():
        if kind == 'std_msgs/Header':
            offsets['header.stamp.sec'], offsets['header.stamp.nanosec'] = pos, pos + 4
            pos += 8 + padding(pos + 8, 4) + 4 + len(msg.header.frame_id.encode()) + 1
        elif kind == 'string':
            pos += padding(pos, 4) + 4 + len(getattr(msg, name).encode()) + 1
        else:
            element, _, width = kind.rstrip(']').partition('[')
            if element not in PRIMITIVE_SIZES:
                raise TypeError(f'{type(msg).__name__}.{name}: {kind} has no fixed CDR layout here')
            pos += padding(pos, PRIMITIVE_SIZES[element])
            offsets[name] = pos
            pos += PRIMITIVE_SIZES[element] * int(width or 1)
    return offsets, pos


def sample_cdr(block, part: int, indices: list[int], templates: dict | None = None) -> list[bytes]:
    """Canonical CDR of the per-sample messages of one part of a block, samples `indices`.

    The first sample, serialized by rclpy, is the template the others' values are written
    into at the fields' offsets (the same bytes, test_export); templates: a cache of them.
    """
    lay = layout(type(block))
    key = (type(block), part, block.header.frame_id, *(getattr(block, c.name) for c in lay.per_block))
    cached = templates.get(key) if templates is not None else None
    if cached is None:
        first = next(expand(block, indices[:1]))[part]
        cached = canonical_bytes(first, serialize_message(first)), _field_offsets(first)
        if cached[0][1] != 1 or ENCAPSULATION_HEADER + cached[1][1] != len(cached[0]):
            raise ValueError(f'{type(first).__name__}: unexpected CDR layout ({len(cached[0])} bytes)')
        if templates is not None:
            templates[key] = cached
    template, (offsets, _) = cached
    if len(indices) <= FEW_SAMPLES:
        return _packed_rows(block, part, indices, template, offsets)
    rows = np.tile(np.frombuffer(template, dtype=np.uint8), (len(indices), 1))
    index = np.asarray(indices)

    def put(field: str, values) -> None:
        raw = np.ascontiguousarray(values).view(np.uint8).reshape(len(index), -1)
        start = ENCAPSULATION_HEADER + offsets[field]
        rows[:, start:start + raw.shape[1]] = raw
    stamps = sample_stamps_ns(block)[index]
    put('header.stamp.sec', (stamps // 1_000_000_000).astype('<i4'))
    put('header.stamp.nanosec', (stamps % 1_000_000_000).astype('<u4'))
    columns = block_columns(block)
    put('step', columns['step'][index].astype('<u8'))
    for column in lay.columns:
        if column.part == part:
            put(column.source, columns[column.name][index].astype('<' + STRUCT_CODES[column.element]))
    return [row.tobytes() for row in rows]


FEW_SAMPLES = 8
"""Up to this many samples of a block (the recorder's decimated viewer topics), sample_cdr packs each
row with struct: fewer calls than numpy's per column, which pays off for many samples."""


def _packed_rows(block, part: int, indices: list[int], template: bytes, offsets: dict[str, int]) -> list[bytes]:
    """sample_cdr's rows for a few samples, each value packed at its field's offset."""
    lay = layout(type(block))
    check_lengths(block, lay)
    fields = [(ENCAPSULATION_HEADER + offsets[c.source], f'<{c.width}{STRUCT_CODES[c.element]}',
               getattr(block, c.name), c.width)
              for c in lay.columns if c.part == part]
    stamp_at = ENCAPSULATION_HEADER + offsets['header.stamp.sec']
    step_at = ENCAPSULATION_HEADER + offsets['step']
    stamps = sample_stamps_ns(block).tolist()
    rows = []
    for i in indices:
        row = bytearray(template)
        struct.pack_into('<iI', row, stamp_at, *divmod(stamps[i], 1_000_000_000))
        struct.pack_into('<Q', row, step_at, block.first_step + i * block.step_stride)
        for at, fmt, values, width in fields:
            struct.pack_into(fmt, row, at, *values[i * width:(i + 1) * width])
        rows.append(bytes(row))
    return rows


def _sorted_profiles(profiles: list) -> list:
    """Offered QoS profiles, duplicates dropped, in a fixed order (discovery order varies between runs)."""
    unique = {qos_yaml.dump([p]): p for p in profiles}
    return [unique[key] for key in sorted(unique)]


def write_canonical(source: Path, writer: BagWriter, samples: SampleTopics | None = None,
                    topics: Iterable[str] | None = None, keep_blocks: bool = True,
                    replace_samples: bool = False, start_ns: int | None = None, end_ns: int | None = None,
                    progress: Callable[[int], None] | None = None) -> None:
    """Copy the complete MCAP file `source` into `writer` in canonical order.

    samples: add its derived topics (one the source holds only with replace_samples, which drops
    the source's); topics: copy only these (or derived from these); keep_blocks False drops the
    block topics; only messages logged in [start_ns, end_ns]; progress(n): n more read.
    """
    with open(source, 'rb') as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        channels = {c.id: c for c in summary.channels.values()}
        present = {c.topic for c in channels.values()}
        wanted = None if topics is None else set(topics)
        derived = {}
        if samples is not None:
            counts = summary.statistics.channel_message_counts if summary.statistics else {}
            busy = sorted(c.topic for c in channels.values() if counts.get(c.id, 0))   # silent blocks: none
            derived = {t: v for t, v in samples.topics_for(busy).items()
                       if (replace_samples or t not in present) and (wanted is None or t in wanted or v[1] in wanted)}
        feeding = {v[1] for v in derived.values()}
        copied = {c.topic for c in channels.values()
                  if (wanted is None or c.topic in wanted) and (keep_blocks or split_namespace(c.topic) is None)
                  and c.topic not in derived}
        entries: dict[str, tuple[TypeDefinition, list]] = {}    # topic -> (definition, QoS profiles)
        for channel in channels.values():
            profiles = _sorted_profiles(qos_yaml.load(channel.metadata.get('offered_qos_profiles')))
            if channel.topic in copied:
                schema = summary.schemas[channel.schema_id]
                entries[channel.topic] = (TypeDefinition(schema.name, schema.data.decode(),
                                                         channel.metadata.get('topic_type_hash', '')), profiles)
            for topic, (type_name, block_topic, _) in derived.items():
                if block_topic == channel.topic:     # a derived topic offers its block topic's QoS
                    entries[topic] = (type_definition(type_name), profiles)
        records: dict[str, TopicRecord] = {topic: writer.add_topic(topic, *entries[topic])
                                           for topic in sorted(entries)}
        wanted_derived = set(derived)
        pending: list[tuple[int, str, int, bytes, int]] = []   # (log time, topic, sequence, data, publish time)
        read = 0
        for _, channel, message in reader.iter_messages(log_time_order=True):
            while pending and pending[0][0] < message.log_time:
                log_time, topic, _, data, publish_time = heapq.heappop(pending)
                writer.write(records[topic], data, log_time, publish_time)
            topic = channel.topic
            if topic in copied and (start_ns is None or message.log_time >= start_ns) and (
                    end_ns is None or message.log_time <= end_ns):
                heapq.heappush(pending, (message.log_time, topic, message.sequence, bytes(message.data),
                                         message.publish_time))
            if topic in feeding:
                for item in samples.derive(topic, message.data, message.log_time, message.publish_time,
                                           wanted_derived):
                    heapq.heappush(pending, (item[1], item[0], 0, item[3], item[2]))
            read += 1
            if progress is not None and read % 1000 == 0:
                progress(1000)
        while pending:
            log_time, topic, _, data, publish_time = heapq.heappop(pending)
            writer.write(records[topic], data, log_time, publish_time)
        if progress is not None:
            progress(read % 1000)


HOLD = 100_000_000
"""ns of sim time a paced topic may fall behind the one furthest ahead and still hold the others back."""


class _Stream:
    """A topic of a :class:`CanonicalWriter`: its channel once written, its latest log time if paced."""

    __slots__ = ('name', 'definition', 'profiles', 'paced', 'latest', 'record', 'derived', 'block', 'taken')

    def __init__(self, name: str, definition: TypeDefinition, profiles: list, paced: bool = False,
                 block: str | None = None) -> None:
        self.name, self.definition, self.profiles, self.paced = name, definition, profiles, paced
        self.latest = -1            # log time of the latest message (paced topics)
        self.record: TopicRecord | None = None
        self.derived: set[str] = set()      # per-sample topics derived from this (block) topic
        self.block = block                  # the block topic this per-sample topic is derived from
        self.taken = 0                      # messages taken: the order of equal log times


class CanonicalWriter:
    """Write a recording into a :class:`BagWriter` in canonical order while it comes.

    Messages wait until :meth:`flush` gets a watermark above their log time (a later one is
    written out of order and counted in ``late``); samples: topics derived from the blocks,
    except ``reserved`` (a block that does not decode is counted in ``underived``).
    """

    def __init__(self, writer: BagWriter, samples: SampleTopics | None = None, reserved: Iterable[str] = ()) -> None:
        self.writer, self.samples, self.reserved = writer, samples, set(reserved)
        self.streams: dict[str, _Stream] = {}
        self.late = 0
        self.underived = 0          # blocks whose per-sample messages could not be derived
        self._pending: list[tuple[int, str, int, bytes, int]] = []   # (log time, topic, n, data, publish time)
        self._written = -1          # log time of the latest message written
        self._first = 1 << 63       # log time of the first paced message

    @property
    def closed(self) -> bool:
        return self.writer.closed

    def add_topic(self, name: str, definition: TypeDefinition, qos_profiles: list | None = None,
                  paced: bool = False) -> _Stream:
        """Declare a topic (its channel is registered at its first message written); paced: see watermark."""
        if name in self.streams:
            raise BagWriteError(f'topic {name!r} registered twice')
        stream = self.streams[name] = _Stream(name, definition, _sorted_profiles(qos_profiles or []), paced)
        if self.samples is not None:
            for topic, (type_name, _, _) in self.samples.topics_for([name]).items():
                if topic not in self.reserved and topic not in self.streams:
                    self.streams[topic] = _Stream(topic, type_definition(type_name), stream.profiles, block=name)
                    stream.derived.add(topic)
        return stream

    def write(self, stream: _Stream, data: bytes, log_time: int, publish_time: int) -> None:
        """Take one message (and the per-sample messages derived from it)."""
        if stream.paced and log_time > stream.latest:
            stream.latest = log_time
            self._first = min(self._first, log_time)
        self._push(stream, log_time, data, publish_time)
        if not stream.derived:
            return
        try:
            rows = list(self.samples.derive(stream.name, data, log_time, publish_time, stream.derived))
        except Exception:  # noqa: BLE001 - a block that does not decode (rclpy raises bare errors)
            self.underived += 1
            return
        for topic, log, publish, row in rows:
            self._push(self.streams[topic], log, row, publish)

    def _push(self, stream: _Stream, log_time: int, data: bytes, publish_time: int) -> None:
        heapq.heappush(self._pending, (log_time, stream.name, stream.taken, data, publish_time))
        stream.taken += 1

    def watermark(self, expected: Iterable[str] = ()) -> int | None:
        """The least latest log time of the paced topics (None: no paced topic, no bound).

        A topic more than HOLD behind the lead (stalled) does not count; one of ``expected``
        that has sent nothing holds it at -1 until the lead is HOLD past the first paced message.
        """
        times = [s.latest for s in self.streams.values() if s.paced]
        if not times:
            return -1 if expected else None
        lead = max(times)
        if lead - self._first <= HOLD and any(name not in self.streams for name in expected):
            return -1
        return min(t for t in times if t >= lead - HOLD)

    def flush(self, watermark: int | None = None, sync_in_background: bool = False) -> None:
        """Write the messages logged before watermark (None: all) in order, then flush the writer."""
        pending = self._pending
        while pending and (watermark is None or pending[0][0] < watermark):
            log_time, name, _, data, publish_time = heapq.heappop(pending)
            stream = self.streams[name]
            if stream.record is None:
                stream.record = self.writer.add_topic(name, stream.definition, stream.profiles)
            if log_time < self._written:
                self.late += 1
            self._written = max(self._written, log_time)
            self.writer.write(stream.record, data, log_time, publish_time)
        self.writer.flush(sync_in_background)

    def close(self, silent: dict[str, tuple[TypeDefinition, list]] | None = None) -> None:
        """Write everything, register the silent topics ({name: (definition, QoS profiles)} too)
        by name, then finish the bag and write metadata.yaml."""
        self.flush()
        for name, (definition, profiles) in (silent or {}).items():
            if name not in self.streams:
                self.add_topic(name, definition, profiles)
        for name in sorted(self.streams):
            stream = self.streams[name]
            if stream.record is None and stream.block is None:
                stream.record = self.writer.add_topic(name, stream.definition, stream.profiles)
        self.writer.close()
