"""Turn the bag of a killed recorder into a complete rosbag2 MCAP bag (``ros2 run drive_logger reindex <bag>``).

The intact records (:func:`drive_logger.bag_reader.intact_records`) are written, unchanged and
in file order, into a complete MCAP file and metadata.yaml; nothing is invented. The data file
is replaced atomically, the original kept as ``<file>.orig``; a complete bag is left as it is
(docs/architecture.md "Bags: log times and crash recovery"). No rclpy here.
"""
from __future__ import annotations

import itertools
import os
import shutil
import sys
from dataclasses import dataclass, field
from pathlib import Path

import yaml
from mcap.records import Channel, Message, Schema

from drive_logger import qos_yaml
from drive_logger.bag_reader import MCAP_MAGIC, check_mcap_file, intact_records, log_time_record
from drive_logger.bag_writer import LOG_TIME_SOURCES, BagWriteError, BagWriter
from drive_logger.message_definitions import TypeDefinition

USAGE = 'usage: ros2 run drive_logger reindex <bag directory>'


class ReindexError(RuntimeError):
    """The bag cannot be reindexed (the message names the file and the problem)."""


@dataclass
class ReindexSummary:
    """What :func:`reindex` did."""

    bag: Path
    data_file: Path
    rewritten: bool                    # False: the bag was already complete
    message_count: int
    topics: dict[str, int] = field(default_factory=dict)   # topic -> messages kept
    kept_aside: Path | None = None     # the original data file's bytes
    damage: str | None = None          # what ended the intact part

    def line(self) -> str:
        if not self.rewritten:
            return f'{self.bag}: already complete ({self.message_count} messages), nothing to do'
        return (f'{self.bag}: reindexed {self.data_file.name}: {self.message_count} messages kept '
                f'({", ".join(f"{t} {n}" for t, n in sorted(self.topics.items())) or "no topic"}); '
                f'original kept as {self.kept_aside.name}; {self.damage}')


def _data_file(bag: Path) -> Path:
    if not bag.exists():
        raise ReindexError(f'bag {str(bag)!r} does not exist')
    if not bag.is_dir():
        raise ReindexError(f'{str(bag)!r} is not a bag directory')
    files = sorted(bag.glob('*.mcap'))
    if len(files) != 1:
        raise ReindexError(f'bag {str(bag)!r} holds {len(files)} .mcap files; reindex handles a bag of one data file')
    return files[0]


def _complete(bag: Path, data: Path) -> int | None:
    """Message count of a complete bag (footer and readable metadata.yaml), else None."""
    if check_mcap_file(data) is not None:
        return None
    try:
        info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
        return int(info['message_count'])
    except (OSError, yaml.YAMLError, KeyError, TypeError, ValueError):
        return None


def _keep_aside(data: Path) -> Path:
    """A hard link (or copy) of data as <file>.orig, or <file>.orig.N if that exists."""
    aside = data.with_name(data.name + '.orig')
    n = 1
    while aside.exists():
        aside = data.with_name(f'{data.name}.orig.{n}')
        n += 1
    try:
        os.link(data, aside)
    except OSError:
        shutil.copy2(data, aside)
    return aside


def _salvage_into(data: Path, tmp: Path, bag: Path) -> tuple[BagWriter, list[str]]:
    """Stream the intact records of data into a complete bag written to tmp; (writer, problems)."""
    problems: list[str] = []
    with open(data, 'rb') as stream:
        if stream.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
            raise ReindexError(f'data file {str(data)!r} is not an MCAP file (bad magic)')
        stream.seek(0)
        records = intact_records(stream, problems, str(data))
        stamp, head = log_time_record(records)     # which clock the log times are on
        log_time = stamp.get('log_time', 'wall')   # bags from before sim-time recording: wall
        writer = BagWriter(bag, log_time=log_time if log_time in LOG_TIME_SOURCES else 'wall',
                           ros_distro=stamp.get('ROS_DISTRO'), data_file=tmp, file_name=data.name)
        try:
            _copy(itertools.chain(head, records), writer, problems, data)
        except BaseException:
            writer.finish_data()
            tmp.unlink(missing_ok=True)
            raise
    return writer, problems


def _copy(records, writer: BagWriter, problems: list[str], data: Path) -> None:
    schemas: dict[int, Schema] = {}
    topics: dict[int, object] = {}
    for record in records:
        if isinstance(record, Schema):
            schemas[record.id] = record
        elif isinstance(record, Channel) and record.id not in topics:
            schema = schemas.get(record.schema_id)
            if schema is None:
                raise ReindexError(f'data file {str(data)!r}: channel {record.topic!r} has no schema')
            definition = TypeDefinition(schema.name, schema.data.decode(),
                                        record.metadata.get('topic_type_hash', ''))
            topics[record.id] = writer.add_topic(
                record.topic, definition, qos_yaml.load(record.metadata.get('offered_qos_profiles')))
        elif isinstance(record, Message):
            topic = topics.get(record.channel_id)
            if topic is None:
                problems.append(f'{str(data)!r}: message on unknown channel {record.channel_id}')
                return
            writer.write(topic, record.data, record.log_time, record.publish_time)


def reindex(path: str | os.PathLike) -> ReindexSummary:
    """Make the bag at path complete (see the module docstring); ReindexError if it cannot."""
    bag = Path(path)
    data = _data_file(bag)
    count = _complete(bag, data)
    if count is not None:
        return ReindexSummary(bag, data, False, count)
    tmp = data.with_name(data.name + '.reindexing')
    try:
        writer, problems = _salvage_into(data, tmp, bag)
        writer.finish_data()
    except (BagWriteError, OSError, UnicodeDecodeError) as exc:
        tmp.unlink(missing_ok=True)
        raise ReindexError(f'cannot reindex {str(data)!r}: {exc}') from exc
    aside = _keep_aside(data)
    os.replace(tmp, data)
    writer.write_metadata_yaml()
    return ReindexSummary(bag, data, True, writer.message_count,
                          {name: t.message_count for name, t in writer.topics.items()}, aside,
                          '; '.join(problems) or 'no damage found')


def main(argv: list[str] | None = None) -> int:
    """``reindex <bag>``: argv without the program name; exit code 0, or 2 with a one-line error."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if len(argv) != 1 or argv[0].startswith('-'):
        print(USAGE, file=sys.stderr)
        return 0 if argv in (['-h'], ['--help']) else 2
    try:
        summary = reindex(argv[0])
    except ReindexError as exc:
        print(f'reindex: error: {exc}', file=sys.stderr)
        return 2
    print(summary.line())
    return 0


if __name__ == '__main__':
    sys.exit(main())
