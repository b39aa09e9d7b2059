"""``ros2 bag record|play|info|reindex`` on drive_logger's recorder, replay, reader and reindex
(rosbag2 ships no wheels); record and play exec the node with rosbag2's options as parameters."""
from __future__ import annotations

import json
import os
import time
from pathlib import Path

from drive_ros2cli.errors import CliError
from drive_ros2cli.verbs.run import executables
from drive_ros2cli.verbs import add_verb

DESCRIPTION = 'Various rosbag related sub-commands'


def add_verbs(verbs) -> None:
    p = add_verb(verbs, 'record', record_main, 'Record ROS data to a bag')
    p.add_argument('topics', nargs='*', default=[],
                   help='List of topics to record (default: the drive graph\'s topics)')
    p.add_argument('-a', '--all', action='store_true', help='Record all topics, also those appearing later')
    p.add_argument('-o', '--output', help='Destination of the bagfile to create (a directory)')
    p.add_argument('-s', '--storage', default='mcap', choices=['mcap'], help='Storage identifier (default: mcap)')
    p.add_argument('--use-sim-time', action='store_true', help='Use simulation time for message timestamps')
    p.add_argument('--compression-format', choices=['lz4', 'zstd', 'none'],
                   help='MCAP chunk compression (default: the recorder\'s, lz4)')

    p = add_verb(verbs, 'play', play_main, 'Play back ROS data from a bag')
    p.add_argument('bag_path', help='Bag to open (directory or .mcap file)')
    p.add_argument('-r', '--rate', type=float, default=1.0, help='rate at which to play back messages (default %(default)s)')
    p.add_argument('-l', '--loop', action='store_true', help='enables loop playback when playing a bagfile')
    p.add_argument('--topics', nargs='+', default=[], help='topics to replay, separated by space')
    p.add_argument('--remap', '-m', nargs='+', default=[], help='list of topics to be remapped: from:=to')
    p.add_argument('--start-offset', type=float, default=0.0, metavar='SEC',
                   help='Start the playback player this many seconds into the bag file')
    p.add_argument('--clock', action='store_true',
                   help='publish /clock (the replay always does, from the recorded stamps)')

    p = add_verb(verbs, 'info', info_main, 'Print information about a bag to the screen')
    p.add_argument('bag_path', help='Bag to open')

    p = add_verb(verbs, 'reindex', reindex_main, 'Reconstruct metadata file for a bag')
    p.add_argument('bag_path', help='Bag to reindex (directory)')


def _exec_node(executable: str, parameters: dict) -> int:
    from drive_ros2cli.verbs.param import parameter_from_value
    path = [p for p in executables('drive_logger') if p.name == executable]
    if not path:
        raise CliError(f"No executable '{executable}' in package 'drive_logger' (run scripts/setup.sh)")
    argv = [str(path[0]), '--ros-args']
    for name, value in parameters.items():
        parameter_from_value(name, value)          # same typing rules as ros2 param set
        argv += ['-p', f'{name}:={json.dumps(value)}']
    os.execv(argv[0], argv)
    return 0


def record_main(args) -> int:
    if args.all and args.topics:
        raise CliError('Invalid choice: cannot specify topics and --all at the same time')
    parameters = {'output': args.output and str(Path(args.output)), 'topics': list(args.topics),
                  'all_topics': args.all, 'use_sim_time': args.use_sim_time,
                  'compression': args.compression_format}
    return _exec_node('recorder', {name: value for name, value in parameters.items() if value})


def play_main(args) -> int:
    if args.rate <= 0:
        raise CliError('rate must be greater than zero')
    if args.start_offset < 0:
        raise CliError('--start-offset must be non-negative')
    parameters: dict = {'bag': args.bag_path, 'rate': float(args.rate), 'loop': bool(args.loop)}
    optional = {'topics': list(args.topics), 'remap': list(args.remap),
                'start_offset': float(args.start_offset)}
    parameters.update({name: value for name, value in optional.items() if value})
    return _exec_node('replay', parameters)


def _size(num_bytes: int) -> str:
    size = float(num_bytes)
    for unit in ('B', 'KiB', 'MiB', 'GiB'):
        if size < 1024 or unit == 'GiB':
            return f'{size:.1f} {unit}' if unit != 'B' else f'{num_bytes} B'
        size /= 1024


def _stamp(ns: int) -> str:
    sec, nsec = divmod(int(ns), 1_000_000_000)
    return f"{time.strftime('%b %e %Y %H:%M:%S', time.localtime(sec))}.{nsec:09d} ({sec}.{nsec:09d})"


def _viewer_note(topic, carried: dict, blocks: dict) -> str:
    """' | Samples: n of N in <block topic>' for a per-sample topic whose samples a block topic holds."""
    if topic.name not in carried or carried[topic.name][0] not in blocks:
        return ''
    block_topic = carried[topic.name][0]
    return f' | Samples: {topic.message_count} of {blocks[block_topic][0]} in {block_topic}'


def info_main(args) -> int:
    from drive_logger.bag_reader import BagReader, BagReadError
    from drive_logger.block_topics import block_sources, block_summaries
    try:
        reader = BagReader(args.bag_path)
        blocks = {}     # every drive's blocks, a namespaced drive's (-r __ns:=/NAME) included
        carried = {}    # per-sample topic -> (block topic, part), likewise
        for namespace in reader.drive_namespaces() or ['']:
            drive = BagReader(args.bag_path, namespace=namespace) if namespace else reader
            blocks.update({namespace + topic: summary
                           for topic, summary in block_summaries(drive).items()})
            carried.update({namespace + topic: (namespace + block_topic, part)
                            for topic, (block_topic, part) in block_sources(drive).items()})
    except BagReadError as exc:
        raise CliError(str(exc)) from None
    meta = reader.metadata or {}
    start = meta.get('starting_time', {}).get('nanoseconds_since_epoch', 0)
    duration = meta.get('duration', {}).get('nanoseconds', 0)
    topics = list(reader.topics.values())
    label = lambda name: f'{name + ":":<19}'  # noqa: E731
    print()
    print(label('Files') + '\n'.join(
        (' ' * 19 if i else '') + f.name for i, f in enumerate(reader.files)))
    print(label('Bag size') + _size(sum(f.stat().st_size for f in reader.files)))
    print(label('Storage id') + meta.get('storage_identifier', 'mcap'))
    print(label('ROS Distro') + str(meta.get('ros_distro', '')))
    print(label('Duration') + f'{duration / 1e9:.9f}s')
    print(label('Start') + _stamp(start))
    print(label('End') + _stamp(start + duration))
    print(label('Messages') + str(meta.get('message_count', 0)))
    lines = [f'Topic: {t.name} | Type: {t.type} | Count: {t.message_count} | Serialization Format: cdr'
             + (f' | Samples: {blocks[t.name][0]}' if t.name in blocks else '')
             + _viewer_note(t, carried, blocks) for t in topics]
    print(label('Topic information') + ('\n' + ' ' * 19).join(lines))
    problems = [f'{topic}: {p}' for topic, (_, found) in blocks.items() for p in found]
    if problems:
        print(label('Block steps') + ('\n' + ' ' * 19).join(problems))
    print(label('Service') + '0')
    print(label('Service information'))
    return 0


def reindex_main(args) -> int:
    from drive_logger import bag_reindex
    if not Path(args.bag_path).is_dir():
        raise CliError(f"bag '{args.bag_path}' is not a bag directory")
    return int(bag_reindex.main([args.bag_path]) or 0)
