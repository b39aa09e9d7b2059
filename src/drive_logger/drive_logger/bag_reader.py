"""Read a rosbag2 MCAP bag without ROS (``mcap`` + ``mcap-ros2-support``).

A bag without ``metadata.yaml`` or with a missing, truncated or corrupt data file is a
:class:`BagReadError` naming the file and the problem; with ``salvage=True`` the intact part
is read instead (:func:`intact_records`, which ``drive_logger.bag_reindex`` uses too).
"""
from __future__ import annotations

import dataclasses
import functools
import io
import os
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Iterator

import yaml
from mcap.exceptions import EndOfFile, McapError
from mcap.reader import make_reader
from mcap.records import Channel, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap_ros2.decoder import DecoderFactory

from drive_logger import qos_yaml
from drive_logger.bag_writer import LOG_TIME_RECORD, OPEN_CHUNK_SUFFIX

MCAP_MAGIC = b'\x89MCAP0\r\n'
SALVAGE_HINT = (' (to use the intact part: --salvage for analyze and compare_replay, '
                '-p salvage:=true for replay, salvage=True in Python)')


class BagReadError(RuntimeError):
    """The bag is missing, truncated or corrupt (the message names the problem)."""


@dataclass
class TopicInfo:
    name: str
    type: str                   # pkg/msg/Type
    message_count: int | None   # None when unknown (salvaged bag without metadata)
    qos_profiles: list = field(default_factory=list)
    type_hash: str = ''


@dataclass
class BagMessage:
    """One message: topic, type, times (ns) and the raw CDR bytes."""

    topic: str
    type: str
    log_time: int
    publish_time: int
    data: bytes
    schema_id: int


def check_mcap_file(path: Path) -> str | None:
    """A description of what is wrong with an MCAP file, or None if its frame is intact."""
    if not path.is_file():
        return f'data file {str(path)!r} is missing'
    size = path.stat().st_size
    if size < 2 * len(MCAP_MAGIC):
        return f'data file {str(path)!r} is truncated ({size} bytes: not even the MCAP header)'
    with open(path, 'rb') as f:
        head = f.read(len(MCAP_MAGIC))
        f.seek(size - len(MCAP_MAGIC))
        tail = f.read(len(MCAP_MAGIC))
    if head != MCAP_MAGIC:
        return f'data file {str(path)!r} is not an MCAP file (bad magic)'
    if tail != MCAP_MAGIC:
        return (f'data file {str(path)!r} is truncated at byte {size}: no MCAP footer '
                '(the recorder did not finalize it)')
    return None


def intact_records(stream, problems: list[str], name: str) -> Iterator[Any]:
    """MCAP records of stream up to the first damaged one (a chunk only whole and CRC-checked),
    then the open chunk flushed beside the file if it belongs there; what ended the intact
    part is appended to problems, naming the file."""
    end = stream.tell()
    try:
        for record in StreamReader(stream, validate_crcs=True).records:
            yield record
            end = stream.tell()
    except Exception as exc:  # noqa: BLE001 - the intact part ends at the first damaged record
        why = ('the file ends inside a record (truncated)' if isinstance(exc, EndOfFile)
               else f'{type(exc).__name__}: {exc}')
        problems.append(f'{name!r}: intact part ends at byte {stream.tell()} ({why})')
        yield from _open_chunk(stream, end, problems, name)


def _open_chunk(stream, end: int, problems: list[str], name: str) -> Iterator[Any]:
    """The records of the open chunk the writer put beside the file (OPEN_CHUNK_SUFFIX) if it
    belongs where the intact part ends: a kill cut the chunk's overwrite in the file."""
    try:
        journal = Path(stream.name + OPEN_CHUNK_SUFFIX).read_bytes()
    except (AttributeError, TypeError, OSError):
        return
    if len(journal) < 8 or struct.unpack_from('<Q', journal)[0] != end:
        return
    try:
        for record in StreamReader(io.BytesIO(journal[8:]), skip_magic=True, validate_crcs=True).records:
            yield record
    except EndOfFile:
        problems.append(f'{name!r}: the open chunk at byte {end} taken from '
                        f'{Path(stream.name).name}{OPEN_CHUNK_SUFFIX}')
    except Exception as exc:  # noqa: BLE001
        problems.append(f'{name!r}: the open chunk beside it is damaged too ({type(exc).__name__}: {exc})')


def log_time_record(records: Iterator[Any]) -> tuple[dict[str, str], list]:
    """The ``drive_logger`` record that follows the MCAP header ({} if there is none before the
    first schema, channel or message), and the records read to find it."""
    head = []
    for record in records:
        head.append(record)
        if isinstance(record, Metadata) and record.name == LOG_TIME_RECORD:
            return record.metadata, head
        if isinstance(record, (Schema, Channel, Message)):
            break
    return {}, head


def intact_messages(stream, problems: list[str], name: str):
    """(schema, channel, message) of every intact message, in file order (see :func:`intact_records`)."""
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    for record in intact_records(stream, problems, name):
        if isinstance(record, Schema):
            schemas[record.id] = record
        elif isinstance(record, Channel):
            channels[record.id] = record
        elif isinstance(record, Message):
            channel = channels.get(record.channel_id)
            if channel is None:
                problems.append(f'{name!r}: message on unknown channel {record.channel_id}; intact part ends here')
                return
            yield schemas.get(channel.schema_id), channel, record


DRIVE_TOPICS = ('/plant/state_block', '/dtc/status_block', '/pfc/status_block', '/plant/state',
                '/dtc/status', '/pfc/status', '/drive/measurement', '/drive/gate_command',
                '/pfc/measurement', '/pfc/duty_command')
"""A drive's topics (drive_common.topics, not imported: this reader needs no ROS): what tells
the namespace of a drive recorded under one."""


class BagReader:
    """A rosbag2 bag directory (or a single .mcap file), read without ROS.

    salvage: read the intact part of a damaged bag (:attr:`problems` says what was found).
    namespace: read only the drive recorded under it (``/drive1``), its topics named without
    it; ``'auto'``: the one namespace holding drive topics; None: every topic as recorded.
    """

    def __init__(self, path: str | os.PathLike, salvage: bool = False,
                 namespace: str | None = None) -> None:
        self.path = Path(path)
        self.salvage = salvage
        self.problems: list[str] = []
        self.metadata: dict[str, Any] | None = None
        if not self.path.exists():
            raise BagReadError(f'bag {str(self.path)!r} does not exist')
        if self.path.is_dir():
            meta, names = self.path / 'metadata.yaml', None
            if not meta.is_file():
                self.problems.append(f'{str(self.path)!r} has no metadata.yaml (bag not finalized)')
            else:
                try:
                    self.metadata = yaml.safe_load(meta.read_text())['rosbag2_bagfile_information']
                    names = self.metadata['relative_file_paths']
                except (yaml.YAMLError, KeyError, TypeError) as exc:
                    self.problems.append(f'metadata.yaml of {str(self.path)!r} is corrupt ({exc})')
                    self.metadata = None
            if names is None:
                names = sorted(p.name for p in self.path.glob('*.mcap'))
                if not names:
                    raise BagReadError(f'{str(self.path)!r} holds no metadata.yaml and no .mcap file')
            self.files = [self.path / Path(n).name for n in names]
        else:
            self.files = [self.path]
        problems = {file: check_mcap_file(file) for file in self.files}
        self._damaged = {file for file, problem in problems.items() if problem}
        self.problems += [problem for problem in problems.values() if problem]
        if self.problems and not salvage:
            raise BagReadError('; '.join(self.problems) + SALVAGE_HINT)
        self._decoders: dict[tuple[Path, int], Any] = {}
        self._factory = DecoderFactory()
        self.namespace = None if namespace is None else self._choose_namespace(namespace)

    def drive_namespaces(self) -> list[str]:
        """Namespaces ('' for none) under which the bag holds a drive's topics."""
        found = set()
        for topic in self.recorded_topics:
            for known in DRIVE_TOPICS:
                if topic.endswith(known):
                    found.add(topic[:-len(known)])
        return sorted(found)

    def _choose_namespace(self, namespace: str) -> str:
        found = self.drive_namespaces()
        listed = ', '.join(ns or '(none)' for ns in found) or 'none'
        if namespace == 'auto':
            if len(found) > 1:
                raise BagReadError(f'bag {str(self.path)!r} holds the drives of several namespaces '
                                   f'({listed}): choose one with --namespace NAME (replay: -p namespace:=NAME)')
            return found[0] if found else ''
        namespace = '/' + namespace.strip('/') if namespace.strip('/') else ''
        if namespace not in found:
            raise BagReadError(f'bag {str(self.path)!r} holds no drive under namespace '
                               f'{namespace or "/"!r} (its namespaces: {listed})')
        return namespace

    @property
    def log_time_source(self) -> str:
        """Clock of the log times, 'sim' or 'wall' (older bags: 'wall')."""
        if self.metadata is not None:
            return (self.metadata.get('custom_data') or {}).get('log_time', 'wall')
        with open(self.files[0], 'rb') as stream:    # not finalized: the record after the header
            return log_time_record(intact_records(stream, [], str(self.files[0])))[0].get('log_time', 'wall')

    @functools.cached_property
    def topics(self) -> dict[str, TopicInfo]:
        """Topic name -> TopicInfo (under the chosen namespace, named without it)."""
        if not self.namespace:
            return self.recorded_topics
        prefix, strip = self.namespace + '/', len(self.namespace)
        return {name[strip:]: dataclasses.replace(info, name=name[strip:])
                for name, info in self.recorded_topics.items() if name.startswith(prefix)}

    @functools.cached_property
    def recorded_topics(self) -> dict[str, TopicInfo]:
        """Topic name as recorded -> TopicInfo, from metadata.yaml (or the MCAP channels; read once)."""
        if self.metadata is not None:
            out = {}
            for entry in self.metadata.get('topics_with_message_count', []):
                meta = entry['topic_metadata']
                out[meta['name']] = TopicInfo(meta['name'], meta['type'], entry.get('message_count'),
                                              qos_yaml.load(meta.get('offered_qos_profiles')),
                                              meta.get('type_description_hash', ''))
            return out
        out = {}
        for file in self.files:
            for schema, channel, _ in self._iter_file(file, only_channels=True):
                if channel.topic not in out:
                    out[channel.topic] = TopicInfo(
                        channel.topic, schema.name if schema else '', None,
                        qos_yaml.load(channel.metadata.get('offered_qos_profiles')),
                        channel.metadata.get('topic_type_hash', ''))
        return out

    def _iter_file(self, file: Path, topics: Iterable[str] | None = None, only_channels: bool = False):
        topics = list(topics) if topics is not None else None
        with open(file, 'rb') as stream:
            if file not in self._damaged:
                try:
                    reader = make_reader(stream)
                    if only_channels:
                        summary = reader.get_summary()
                        for channel in summary.channels.values():
                            yield summary.schemas.get(channel.schema_id), channel, None
                        return
                    yield from reader.iter_messages(topics=topics, log_time_order=True)
                    return
                except (McapError, EOFError, ValueError, KeyError, OSError, RuntimeError) as exc:
                    problem = f'data file {str(file)!r} is corrupt: {type(exc).__name__}: {exc}'
                    if not self.salvage:
                        raise BagReadError(problem + SALVAGE_HINT) from exc
                    self.problems.append(problem)
                    self._damaged.add(file)
                    stream.seek(0)
            seen_channels = set()
            problems = [] if only_channels else self.problems
            for schema, channel, message in intact_messages(stream, problems, str(file)):
                if only_channels:
                    if channel.id not in seen_channels:
                        seen_channels.add(channel.id)
                        yield schema, channel, None
                    continue
                if topics is None or channel.topic in topics:
                    yield schema, channel, message

    def messages(self, topics: Iterable[str] | None = None) -> Iterator[BagMessage]:
        """Every message (of the given topics), file by file, in log-time order."""
        return (message for _, message in self._messages(topics))

    def _messages(self, topics: Iterable[str] | None):
        """(schema, BagMessage) of every message of topics (named without the namespace)."""
        strip = len(self.namespace or '')
        if strip:
            topics = [self.namespace + t for t in (self.topics if topics is None else topics)]
        for file in self.files:
            for schema, channel, message in self._iter_file(file, topics):
                yield schema, BagMessage(channel.topic[strip:], schema.name if schema else '',
                                         message.log_time, message.publish_time,
                                         bytes(message.data), schema.id if schema else 0)

    def decode(self, msg: BagMessage, schema=None) -> Any:
        """Decode a message's CDR with its schema (mcap-ros2-support dynamic types)."""
        key = (msg.type, msg.schema_id)
        decoder = self._decoders.get(key)
        if decoder is None:
            if schema is None:
                schema = self._schema_for(msg.type)
            decoder = self._factory.decoder_for('cdr', schema)
            self._decoders[key] = decoder
        return decoder(msg.data)

    def _schema_for(self, type_name: str):
        for file in self.files:
            for schema, _, _ in self._iter_file(file, only_channels=True):
                if schema is not None and schema.name == type_name:
                    return schema
        raise BagReadError(f'no schema for {type_name!r} in {str(self.path)!r}')

    def decoded_messages(self, topics: Iterable[str] | None = None) -> Iterator[tuple[BagMessage, Any]]:
        """(BagMessage, decoded message) pairs."""
        for schema, msg in self._messages(topics):
            yield msg, self.decode(msg, schema)
