"""rosbag2-layout (Jazzy, metadata version 9) MCAP bag writer on the ``mcap`` library, without rclpy.

A new directory ``<dir>`` holding ``<dir>_0.mcap`` and, once closed, ``metadata.yaml``: one
``ros2msg`` schema per type, one ``cdr`` channel per topic, the caller's CDR bytes at the log
and publish times it gives, chunks cut by size only; :meth:`BagWriter.flush` puts the open
chunk on disk for crash recovery (docs/architecture.md "Bags").
"""
from __future__ import annotations

import os
import struct
import threading
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml
from mcap.data_stream import RecordBuilder
from mcap.records import Chunk
from mcap.writer import CompressionType, Writer, lz4, zstandard

from drive_logger import qos_yaml
from drive_logger.message_definitions import (NODE_STAMP, SAMPLE_STAMP, TypeDefinition, cdr_stamp_ns,
                                              is_sim_stamp)

METADATA_VERSION = 9
LOG_TIME_SOURCES = ('sim', 'wall')
"""Clock of the log times: 'sim' (the sample's sim time, as ``ros2 bag record
--use-sim-time``) or 'wall' (receive time, ns since the epoch)."""
LOG_TIME_RECORD = 'drive_logger'
"""Name of the MCAP metadata record, written first, that says which clock the log times are on."""
COMPRESSION = {'none': CompressionType.NONE, 'lz4': CompressionType.LZ4, 'zstd': CompressionType.ZSTD}
_COMPRESS = {'none': ('', bytes), 'lz4': ('lz4', lambda data: lz4.frame.compress(data)),
             'zstd': ('zstd', lambda data: zstandard.compress(data))}
"""The chunk record's compression name and function, as mcap's writer does it."""
OPEN_CHUNK_SUFFIX = '.open-chunk'
"""Beside the data file while recording: the offset (uint64) and record of the open chunk last flushed."""


class BagWriteError(RuntimeError):
    """The bag cannot be created or written (message names the cause)."""


@dataclass
class TopicRecord:
    """One topic of the bag: its channel and how many messages it holds."""

    name: str
    definition: TypeDefinition
    qos_profiles: list = field(default_factory=list)
    channel_id: int = -1
    message_count: int = 0


def check_output_directory(path: str | os.PathLike) -> Path:
    """Raise BagWriteError unless path does not exist and its parent can be written."""
    path = Path(path)
    if path.is_dir() and any(path.glob('*.mcap')) and not (path / 'metadata.yaml').exists():
        raise BagWriteError(
            f'output directory {str(path)!r} holds a bag that was never finalized (recorder killed?): '
            f'recover it with `ros2 run drive_logger reindex {path}` or choose another output')
    if path.exists():
        raise BagWriteError(f'output directory {str(path)!r} already exists: refusing to overwrite a bag')
    parent = path.absolute().parent
    existing = parent
    while not existing.exists():
        existing = existing.parent
    if not existing.is_dir() or not os.access(existing, os.W_OK | os.X_OK):
        raise BagWriteError(f'cannot create output directory {str(path)!r}: {str(existing)!r} is not writable')
    return path


class BagWriter:
    """Write one rosbag2 MCAP bag into the new directory path; a context manager, or call :meth:`close`.

    compression: 'lz4', 'zstd' or 'none'; chunk_size: uncompressed bytes per chunk; log_time: one
    of :data:`LOG_TIME_SOURCES`; data_file: write the MCAP data there instead, path existing
    (:mod:`drive_logger.bag_reindex`); file_name: the data file's name in metadata.yaml.
    """

    def __init__(self, path: str | os.PathLike, compression: str = 'lz4',
                 chunk_size: int = 1 << 20, ros_distro: str | None = None, log_time: str = 'sim',
                 data_file: str | os.PathLike | None = None, file_name: str | None = None) -> None:
        if compression not in COMPRESSION:
            raise BagWriteError(f'unknown compression {compression!r}; use one of {sorted(COMPRESSION)}')
        if log_time not in LOG_TIME_SOURCES:
            raise BagWriteError(f'unknown log time source {log_time!r}; use one of {list(LOG_TIME_SOURCES)}')
        self.path = Path(path) if data_file is not None else check_output_directory(path)
        self.ros_distro = ros_distro or os.environ.get('ROS_DISTRO', 'jazzy')
        self.compression = compression
        self.chunk_size = chunk_size
        self.log_time = log_time
        self.file_name = file_name or f'{self.path.name}_0.mcap'
        self.data_file = Path(data_file) if data_file is not None else self.path / self.file_name
        if data_file is None:
            try:
                self.path.mkdir(parents=True)
            except OSError as exc:
                raise BagWriteError(f'cannot create output directory {str(self.path)!r}: {exc}') from exc
        self._stream = open(self.data_file, 'wb')
        try:
            self._writer = Writer(self._stream, chunk_size=chunk_size, compression=COMPRESSION[compression])
        except Exception as exc:  # e.g. mcap's UnsupportedCompressionError
            self._stream.close()
            self.data_file.unlink()
            if data_file is None:
                self.path.rmdir()
            raise BagWriteError(f'compression {compression!r} unavailable: {exc}') from exc
        self._writer.start(profile='ros2', library='drive_logger (mcap-python)')
        self._writer.add_metadata(LOG_TIME_RECORD, {'log_time': log_time, 'ROS_DISTRO': self.ros_distro})
        self._schemas: dict[str, int] = {}
        self.topics: dict[str, TopicRecord] = {}
        self.start_ns: int | None = None
        self.end_ns = 0
        self.message_count = 0
        self.closed = False
        self._syncer: threading.Thread | None = None
        self._sync_wanted = threading.Event()
        self._stop_syncing = False
        self._flushed = (0, 0)          # (offset, size) of the open chunk last flushed

    def add_topic(self, name: str, definition: TypeDefinition, qos_profiles: list | None = None) -> TopicRecord:
        """Register a topic (channel, and its type's schema once); return its record."""
        if name in self.topics:
            raise BagWriteError(f'topic {name!r} registered twice')
        schema_id = self._schemas.get(definition.name)
        if schema_id is None:
            schema_id = self._writer.register_schema(
                name=definition.name, encoding='ros2msg', data=definition.text.encode())
            self._schemas[definition.name] = schema_id
        record = TopicRecord(name, definition, list(qos_profiles or []))
        record.channel_id = self._writer.register_channel(
            topic=name, message_encoding='cdr', schema_id=schema_id,
            metadata={'offered_qos_profiles': qos_yaml.dump(record.qos_profiles),
                      'topic_type_hash': definition.type_hash})
        self.topics[name] = record
        return record

    def write(self, topic: TopicRecord, data: bytes, log_time_ns: int, publish_time_ns: int) -> None:
        """Append one serialized (CDR) message of a registered topic."""
        self._writer.add_message(topic.channel_id, log_time=log_time_ns, data=data,
                                 publish_time=publish_time_ns, sequence=topic.message_count)
        topic.message_count += 1
        self.message_count += 1
        if self.start_ns is None or log_time_ns < self.start_ns:
            self.start_ns = log_time_ns
        if log_time_ns > self.end_ns:
            self.end_ns = log_time_ns

    def metadata(self) -> dict[str, Any]:
        """The ``rosbag2_bagfile_information`` mapping of metadata.yaml."""
        start = self.start_ns or 0
        duration = max(0, self.end_ns - start) if self.message_count else 0
        return {
            'version': METADATA_VERSION,
            'storage_identifier': 'mcap',
            'duration': {'nanoseconds': duration},
            'starting_time': {'nanoseconds_since_epoch': start},
            'message_count': self.message_count,
            'topics_with_message_count': [{
                'topic_metadata': {
                    'name': t.name,
                    'type': t.definition.name,
                    'serialization_format': 'cdr',
                    'offered_qos_profiles': t.qos_profiles,
                    'type_description_hash': t.definition.type_hash,
                },
                'message_count': t.message_count,
            } for t in self.topics.values()],
            # MCAP chunk compression is internal to the storage: rosbag2 reports none here.
            'compression_format': '',
            'compression_mode': '',
            'relative_file_paths': [self.file_name],
            'files': [{
                'path': self.file_name,
                'starting_time': {'nanoseconds_since_epoch': start},
                'duration': {'nanoseconds': duration},
                'message_count': self.message_count,
            }],
            'custom_data': {'log_time': self.log_time},
            'ros_distro': self.ros_distro,
        }

    def flush(self, sync_in_background: bool = False) -> None:
        """Put the open chunk on disk where its final form overwrites it, and into
        ``<data file>.open-chunk`` with its offset, then fsync (on a helper thread with
        sync_in_background); the chunk stays open (docs/architecture.md "Bags": Flush)."""
        if self.closed:
            return
        self._write_open_chunk()
        if not sync_in_background:
            os.fsync(self._stream.fileno())
            return
        if self._syncer is None:
            self._syncer = threading.Thread(target=self._sync_loop, name='bag fsync', daemon=True)
            self._syncer.start()
        self._sync_wanted.set()

    def _write_open_chunk(self) -> None:
        builder = self._writer._Writer__chunk_builder    # mcap's writer keeps its open chunk private
        end = self._stream.tell()
        if not builder.num_messages or self._flushed == (end, builder.count):   # nothing new (a hold)
            return
        self._flushed = (end, builder.count)
        data = builder.record_writer._buffer.getvalue()
        name, compress = _COMPRESS[self.compression]
        record = RecordBuilder()
        Chunk(compression=name, data=compress(data), message_start_time=builder.message_start_time,
              message_end_time=builder.message_end_time, uncompressed_crc=zlib.crc32(data),
              uncompressed_size=len(data)).write(record)
        chunk = record.end()
        journal = self.data_file.with_name(self.data_file.name + OPEN_CHUNK_SUFFIX)
        tmp = journal.with_name(journal.name + '.tmp')
        tmp.write_bytes(struct.pack('<Q', end) + chunk)
        os.replace(tmp, journal)
        self._stream.write(chunk)
        self._stream.truncate()
        self._stream.flush()
        self._stream.seek(end)      # where mcap's writer goes on

    def _sync_loop(self) -> None:
        while True:
            self._sync_wanted.wait()
            self._sync_wanted.clear()
            if self._stop_syncing:
                return
            os.fsync(self._stream.fileno())

    def finish_data(self) -> None:
        """Finish the MCAP file (summary, indexes, rosbag2 metadata record) and fsync it."""
        if self.closed:
            return
        self.closed = True
        if self._syncer is not None:
            self._stop_syncing = True
            self._sync_wanted.set()
            self._syncer.join()
        serialized = yaml.safe_dump(self.metadata(), default_flow_style=False, sort_keys=False)
        self._writer.add_metadata('rosbag2', {'serialized_metadata': serialized, 'ROS_DISTRO': self.ros_distro})
        self._writer.finish()
        self._stream.truncate()     # what is left of a longer open chunk flushed before
        self._stream.flush()
        os.fsync(self._stream.fileno())
        self._stream.close()
        self.data_file.with_name(self.data_file.name + OPEN_CHUNK_SUFFIX).unlink(missing_ok=True)

    def write_metadata_yaml(self) -> None:
        """Write metadata.yaml atomically (temporary file, then rename)."""
        tmp = self.path / 'metadata.yaml.tmp'
        tmp.write_text(yaml.safe_dump({'rosbag2_bagfile_information': self.metadata()},
                                      default_flow_style=False, sort_keys=False))
        tmp.replace(self.path / 'metadata.yaml')

    def close(self) -> None:
        """Finish the MCAP file and write metadata.yaml."""
        if not self.closed:
            self.finish_data()
            self.write_metadata_yaml()

    def __enter__(self) -> 'BagWriter':
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class SimTimeLog:
    """Sim-time log times for a :class:`BagWriter` or a :class:`drive_logger.sample_topics.CanonicalWriter`.

    A message with a sim stamp (:func:`message_definitions.sim_stamp_kind`,
    :func:`message_definitions.is_sim_stamp`) is logged at it; any other waits for
    :meth:`end_of_wakeup` and is logged at the latest sample stamp taken by then
    (docs/architecture.md "Bags").
    """

    def __init__(self, writer: BagWriter) -> None:
        self.writer = writer
        self.now_ns = 0                 # latest sample stamp taken
        self._waiting: list[tuple[TopicRecord, bytes]] = []

    def write(self, topic: TopicRecord, data: bytes, kind: str) -> None:
        """kind: the topic type's :func:`message_definitions.sim_stamp_kind`."""
        if kind == SAMPLE_STAMP:
            stamp = cdr_stamp_ns(data)
            if stamp > self.now_ns:
                self.now_ns = stamp
            self.writer.write(topic, data, stamp, stamp)
        elif kind == NODE_STAMP and is_sim_stamp(stamp := cdr_stamp_ns(data)):
            self.writer.write(topic, data, stamp, stamp)
        else:
            self._waiting.append((topic, data))

    def end_of_wakeup(self) -> None:
        """Write the waiting messages at the sim time reached."""
        if self._waiting and not self.writer.closed:
            for topic, data in self._waiting:
                self.writer.write(topic, data, self.now_ns, self.now_ns)
        self._waiting.clear()
