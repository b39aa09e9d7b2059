"""rosbag2-layout (Jazzy, metadata version 9) MCAP bag writer on the ``mcap`` library.

Layout (DESIGN.md §8): a new directory ``<dir>`` holding ``<dir>_0.mcap`` and,
once closed, ``metadata.yaml``. The MCAP file has profile ``ros2``, one
``ros2msg`` schema per type, one ``cdr`` channel per topic whose metadata holds
``offered_qos_profiles`` (the same YAML as metadata.yaml) and
``topic_type_hash``, messages with log_time = receive time and publish_time =
send time (ns since the epoch), and a ``rosbag2`` metadata record holding the
serialized metadata. Messages are appended to chunks of ``chunk_size`` bytes
that are compressed and streamed to disk, so memory stays bounded.

No rclpy here: message data are the exact CDR bytes the caller took from a
raw subscription.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml
from mcap.writer import CompressionType, Writer

from drive_logger import qos_yaml
from drive_logger.message_definitions import TypeDefinition

METADATA_VERSION = 9
COMPRESSION = {'none': CompressionType.NONE, 'lz4': CompressionType.LZ4, 'zstd': CompressionType.ZSTD}


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

    def metadata_entry(self) -> dict[str, Any]:
        return {
            'topic_metadata': {
                'name': self.name,
                'type': self.definition.name,
                'serialization_format': 'cdr',
                'offered_qos_profiles': self.qos_profiles,
                'type_description_hash': self.definition.type_hash,
            },
            'message_count': self.message_count,
        }


def check_output_directory(path: str | os.PathLike) -> Path:
    """Raise BagWriteError unless path does not exist and its parent can be written."""
    path = Path(path)
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
    """Write one rosbag2 MCAP bag; use as a context manager or call :meth:`close`.

    :param path: bag directory to create (must not exist).
    :param compression: MCAP chunk compression: 'lz4' (default), 'zstd' (needs the
        ``zstandard`` module) or 'none'.
    :param chunk_size: uncompressed chunk size in bytes before it is flushed to disk.
    """

    def __init__(self, path: str | os.PathLike, compression: str = 'lz4',
                 chunk_size: int = 1 << 20, ros_distro: str | None = None) -> None:
        if compression not in COMPRESSION:
            raise BagWriteError(f'unknown compression {compression!r}; use one of {sorted(COMPRESSION)}')
        self.path = check_output_directory(path)
        self.ros_distro = ros_distro or os.environ.get('ROS_DISTRO', 'jazzy')
        self.compression = compression
        self.file_name = f'{self.path.name}_0.mcap'
        try:
            self.path.mkdir(parents=True)
        except OSError as exc:
            raise BagWriteError(f'cannot create output directory {str(self.path)!r}: {exc}') from exc
        self._stream = open(self.path / self.file_name, 'wb')
        try:
            self._writer = Writer(self._stream, chunk_size=chunk_size, compression=COMPRESSION[compression])
        except Exception as exc:  # e.g. mcap's UnsupportedCompressionError
            self._stream.close()
            (self.path / self.file_name).unlink()
            self.path.rmdir()
            raise BagWriteError(f'compression {compression!r} unavailable: {exc}') from exc
        self._writer.start(profile='ros2', library='drive_logger (mcap-python)')
        self._schemas: dict[str, int] = {}
        self.topics: dict[str, TopicRecord] = {}
        self.start_ns: int | None = None
        self.end_ns = 0
        self.message_count = 0
        self.closed = False

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
            'topics_with_message_count': [t.metadata_entry() for t in self.topics.values()],
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
            'custom_data': None,
            'ros_distro': self.ros_distro,
        }

    def close(self) -> None:
        """Finish the MCAP file (summary, indexes, metadata record) and write metadata.yaml."""
        if self.closed:
            return
        self.closed = True
        info = self.metadata()
        serialized = yaml.safe_dump(info, default_flow_style=False, sort_keys=False)
        self._writer.add_metadata('rosbag2', {'serialized_metadata': serialized, 'ROS_DISTRO': self.ros_distro})
        self._writer.finish()
        self._stream.flush()
        os.fsync(self._stream.fileno())
        self._stream.close()
        tmp = self.path / 'metadata.yaml.tmp'
        tmp.write_text(yaml.safe_dump({'rosbag2_bagfile_information': info},
                                      default_flow_style=False, sort_keys=False))
        tmp.replace(self.path / 'metadata.yaml')

    def __enter__(self) -> 'BagWriter':
        return self

    def __exit__(self, *exc) -> None:
        self.close()
