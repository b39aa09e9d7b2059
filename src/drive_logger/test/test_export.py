"""Bags for viewers and tables: the canonical file order, the recorder's viewer topics, and
``drive_logger export`` to a full-rate viewer bag and to Parquet/CSV tables (bags written from a
headless run: no graph needed)."""
import random

import numpy as np
import pytest

from drive_logger import export
from drive_logger.bag_reader import BagReader
from drive_logger.bag_writer import BagWriter
from drive_logger.sample_topics import CanonicalWriter, SampleTopics
from drive_common.cdr_padding import canonicalize
from drive_logger.ros_types import message_class
from drive_testing.block_bags import scenario_bags

SCENARIO = 'two_phase_six_switch_torque_step'
DURATION = 0.012      # s: 360 controller samples at 1/30 kHz, the torque step at 9.4 ms included
PER_SAMPLE_TOPICS = ('/plant/state', '/dtc/status', '/drive/measurement', '/drive/gate_command')


@pytest.fixture(scope='module')
def bags(tmp_path_factory):
    return scenario_bags(SCENARIO, DURATION, tmp_path_factory.mktemp('export'))[1]   # + decimated live topics


def _by_topic(reader, topics):
    out = {}
    for msg in reader.messages(topics):
        out.setdefault(msg.topic, []).append((msg.log_time, canonicalize(msg.data, message_class(msg.type))))
    return out


def _recorded(source, path, seed: int, samples=None) -> CanonicalWriter:
    """The messages of source recorded as the recorder takes them: each topic in its order, the
    topics interleaved at random (equal log times in varying order), flushed at random up to the
    watermark of the paced topics; then closed."""
    from drive_logger.graph_topics import is_paced
    reader = BagReader(source)
    bag = CanonicalWriter(BagWriter(path, chunk_size=4096), samples, reserved=reader.topics)
    streams = {}
    for msg in reader.messages():
        streams.setdefault(msg.topic, []).append(msg)
    from drive_logger.message_definitions import TypeDefinition
    records = {}
    rng = random.Random(seed)
    paced = [t for t in streams if is_paced(reader.topics[t].type)]
    while streams:
        topic = rng.choice(sorted(streams))
        msg = streams[topic].pop(0)
        if not streams[topic]:
            del streams[topic]
        if topic not in records:
            info = reader.topics[topic]
            definition = TypeDefinition(info.type, reader._schema_for(info.type).data.decode(), info.type_hash)
            records[topic] = bag.add_topic(topic, definition, info.qos_profiles, paced=topic in paced)
        bag.write(records[topic], msg.data, msg.log_time, msg.publish_time)
        if rng.random() < 0.05:
            bag.flush(bag.watermark(paced))
    bag.close()
    return bag


def test_recorded_bag_does_not_depend_on_arrival_order_or_flushes_and_adds_viewer_topics(bags, tmp_path):
    files = []
    for seed in (1, 2):
        # same bag name (the file names itself in its rosbag2 record)
        bag = _recorded(bags['blocks'], tmp_path / f'run{seed}' / 'bag', seed, SampleTopics(1e-3))
        assert bag.late == 0 and bag.underived == 0
        files.append(bag.writer.data_file.read_bytes())
        assert (tmp_path / f'run{seed}' / 'bag' / 'metadata.yaml').exists()
    assert files[0] == files[1]
    meta = [(tmp_path / f'run{seed}' / 'bag' / 'metadata.yaml').read_text() for seed in (1, 2)]
    assert meta[0] == meta[1]
    reader = BagReader(tmp_path / 'run1' / 'bag')
    # the bag already held decimated /plant/state and /dtc/status: kept as they are, not derived twice
    assert reader.topics['/plant/state'].message_count == BagReader(bags['blocks']).topics['/plant/state'].message_count
    times = [m.log_time for m in reader.messages()]
    assert times == sorted(times)


def test_viewer_topics_are_derived_at_the_viewer_period(bags, tmp_path):
    from rclpy.serialization import deserialize_message
    from dtc_msgs.msg import PlantState
    without_live = [t for t in BagReader(bags['blocks']).topics if t not in PER_SAMPLE_TOPICS]
    writer = BagWriter(tmp_path / 'src')
    source = BagReader(bags['blocks'])
    from drive_logger.sample_topics import write_canonical
    write_canonical(source.files[0], writer, topics=without_live)
    writer.close()
    out = _recorded(tmp_path / 'src', tmp_path / 'viewer', 3, SampleTopics(1e-3)).writer
    reader = BagReader(out.path)
    assert {'/plant/state', '/dtc/status'} <= set(reader.topics)
    states = [(m.log_time, deserialize_message(m.data, PlantState)) for m in reader.messages(['/plant/state'])]
    # one sample per ms of sim time (the plant's 1/30 kHz tick: the first at or after each ms)
    assert [s.step for _, s in states] == [int(np.ceil(k * 30)) for k in range(13)]
    assert all(t == s.header.stamp.sec * 10**9 + s.header.stamp.nanosec for t, s in states)
    full = {s.step: canonicalize(d, PlantState)
            for _, d in _by_topic(BagReader(bags['per_sample']), ['/plant/state'])['/plant/state']
            for s in [deserialize_message(d, PlantState)]}
    for m in reader.messages(['/plant/state']):
        assert canonicalize(m.data, message_class(m.type)) == full[deserialize_message(m.data, PlantState).step]


def test_full_rate_viewer_bag_has_every_sample_bit_exact(bags, tmp_path):
    out = tmp_path / 'viewer'
    assert export.main([str(bags['blocks']), '--to', 'mcap', str(out), '--quiet']) == 0
    reader = BagReader(out)
    assert (out / 'metadata.yaml').exists() and not any(t.endswith('_block') for t in reader.topics)
    expected = _by_topic(BagReader(bags['per_sample']), PER_SAMPLE_TOPICS)
    got = _by_topic(reader, PER_SAMPLE_TOPICS)
    for topic in PER_SAMPLE_TOPICS:
        assert got[topic] == expected[topic], topic
    from rosbags.rosbag2 import Reader
    with Reader(out) as rosbags_reader:      # a third-party reader of rosbag2 bags
        assert rosbags_reader.message_count == reader.metadata['message_count']


def test_parquet_and_csv_tables_hold_the_block_samples_bit_exact(bags, tmp_path):
    from drive_analysis.bag_columns import load_columns
    import pandas as pd
    bag_columns = load_columns(str(bags['blocks']))
    for fmt in ('parquet', 'csv'):
        out = tmp_path / fmt
        assert export.main([str(bags['blocks']), '--to', fmt, str(out), '--quiet']) == 0
        assert sorted(p.name for p in out.iterdir()) == [f'dtc_status.{fmt}', f'plant_state.{fmt}']
        table_columns = load_columns(str(out))       # analyze takes an export directory too
        assert set(table_columns) == set(bag_columns)
        for topic, columns in bag_columns.items():
            assert set(table_columns[topic]) == set(columns), topic
            for name, values in columns.items():
                got = table_columns[topic][name]
                assert got.dtype == values.dtype and got.shape == values.shape, (topic, name)
                if values.dtype == object:
                    same = (got == values).all()
                elif fmt == 'parquet':      # bit for bit, NaN payloads included
                    same = np.array_equal(got.view(np.uint64), values.view(np.uint64))
                else:                       # exact numbers, NaN as NaN
                    same = np.array_equal(got, values, equal_nan=True)
                assert same, (fmt, topic, name)
    table = pd.read_parquet(tmp_path / 'parquet' / 'plant_state.parquet')
    assert list(table.columns[:5]) == ['time', 'step', 'phase_current_a', 'phase_current_b', 'phase_current_c']
    assert {'applied_switch_on_1', 'applied_switch_on_6', 'mechanical_speed'} <= set(table.columns)
    assert table['step'].tolist() == list(range(361))
    status = pd.read_parquet(tmp_path / 'parquet' / 'dtc_status.parquet')
    assert {'measurement_phase_current_c', 'command_switch_on_6', 'mode', 'flux_alpha'} <= set(status.columns)


def test_export_options_select_topics_time_and_every_nth(bags, tmp_path, capsys):
    import pandas as pd
    out = tmp_path / 'part'
    assert export.main([str(bags['blocks']), '--to', 'parquet', str(out), '--topics', '/plant/state',
                        '--start', '0.001', '--end', '0.002', '--every', '3', '--quiet']) == 0
    assert [p.name for p in out.iterdir()] == ['plant_state.parquet']
    table = pd.read_parquet(out / 'plant_state.parquet')
    assert table['step'].tolist() == list(range(30, 61, 3))      # 1 ms .. 2 ms at 1/30 kHz, every 3rd
    viewer = tmp_path / 'viewer_part'
    assert export.main([str(bags['blocks']), '--to', 'mcap', str(viewer), '--topics', '/dtc/status',
                        '--every', '10', '--quiet']) == 0
    reader = BagReader(viewer)
    assert list(reader.topics) == ['/dtc/status'] and reader.topics['/dtc/status'].message_count == 36
    capsys.readouterr()
    assert export.main([str(bags['blocks']), '--to', 'csv', str(out), '--quiet']) == 2
    assert export.main([str(bags['blocks']), '--to', 'csv', str(tmp_path / 'x'), '--every', '0']) == 2
    assert export.main([str(tmp_path / 'missing'), '--to', 'csv', str(tmp_path / 'y')]) == 2
    errors = capsys.readouterr().err.strip().splitlines()
    assert len(errors) == 3 and all(line.startswith('export: ') for line in errors)
    assert 'already exists' in errors[0] and '--every' in errors[1] and 'does not exist' in errors[2]


def test_watermark_waits_for_each_paced_topic_for_a_while_and_a_late_message_is_still_written(tmp_path):
    from rclpy.serialization import serialize_message
    from rosgraph_msgs.msg import Clock
    from drive_logger.message_definitions import type_definition
    from drive_logger.sample_topics import HOLD

    def clock(ns):
        msg = Clock()
        msg.clock.sec, msg.clock.nanosec = divmod(ns, 10**9)
        return serialize_message(msg)
    bag = CanonicalWriter(BagWriter(tmp_path / 'bag'))
    definition = type_definition('rosgraph_msgs/msg/Clock')
    expected = ['/a', '/b', '/silent']
    assert bag.watermark(expected) == -1 and bag.watermark() is None    # nothing yet; nothing paced
    a = bag.add_topic('/a', definition, paced=True)
    for ns in range(0, HOLD // 2, 10**6):
        bag.write(a, clock(ns), ns, ns)
    b = bag.add_topic('/b', definition, paced=True)          # its first message comes later
    bag.write(b, clock(0), 0, 0)
    assert bag.watermark(expected) == -1                     # /silent may still come
    for ns in range(HOLD // 2, 2 * HOLD, 10**6):
        bag.write(a, clock(ns), ns, ns)
    bag.write(b, clock(HOLD + 10**6), HOLD + 10**6, HOLD + 10**6)
    assert bag.watermark(expected) == HOLD + 10**6     # /silent counts as absent now
    bag.flush(bag.watermark(expected))
    assert bag.writer.topics['/a'].message_count == HOLD // 10**6 + 1 and bag.late == 0
    for ns in range(2 * HOLD, 4 * HOLD, 10**6):
        bag.write(a, clock(ns), ns, ns)
    assert bag.watermark(expected) == 4 * HOLD - 10**6         # /b, stalled for longer than HOLD, does not count
    other = bag.add_topic('/other', definition)              # not paced: expected before the watermark
    bag.write(other, clock(5), 5, 5)
    bag.close()
    assert bag.late == 1
    reader = BagReader(tmp_path / 'bag')
    assert [m.log_time for m in reader.messages(['/b'])] == [0, HOLD + 10**6]
    assert [m.log_time for m in reader.messages(['/other'])] == [5]
    assert reader.topics['/a'].message_count == 4 * HOLD // 10**6


def test_a_block_that_does_not_decode_is_recorded_without_viewer_messages(bags, tmp_path):
    from drive_logger.message_definitions import type_definition
    block = next(BagReader(bags['blocks']).messages(['/plant/state_block']))
    bag = CanonicalWriter(BagWriter(tmp_path / 'bag'), SampleTopics(1e-3))
    stream = bag.add_topic('/plant/state_block', type_definition('dtc_msgs/msg/PlantStateBlock'), paced=True)
    bag.write(stream, block.data[:40], 0, 0)                     # cut: does not decode
    bag.write(stream, block.data, block.log_time, block.publish_time)
    bag.close()
    assert bag.underived == 1
    reader = BagReader(tmp_path / 'bag')
    assert reader.topics['/plant/state_block'].message_count == 2 and reader.topics['/plant/state'].message_count


def test_a_namespaced_drives_blocks_give_its_viewer_topics_under_its_namespace(bags):
    """A drive recorded under -r __ns:=/drive1 gets /drive1/plant/state etc., the same samples."""
    samples, plain = SampleTopics(0.0, parts=(0, 1, 2)), SampleTopics(0.0, parts=(0, 1, 2))
    topics = samples.topics_for(['/drive1/plant/state_block', '/drive1/dtc/status_block', '/drive1/clock'])
    assert topics == {'/drive1' + t: (type_name, '/drive1' + block, part) for t, (type_name, block, part)
                      in plain.topics_for(['/plant/state_block', '/dtc/status_block']).items()}
    assert set(topics) == {'/drive1/plant/state', '/drive1/dtc/status', '/drive1/drive/measurement',
                           '/drive1/drive/gate_command'}
    for msg in BagReader(bags['blocks']).messages(['/plant/state_block', '/dtc/status_block']):
        derived = list(samples.derive('/drive1' + msg.topic, msg.data, msg.log_time, msg.publish_time))
        expected = list(plain.derive(msg.topic, msg.data, msg.log_time, msg.publish_time))
        assert derived and [('/drive1' + t, *rest) for t, *rest in expected] == derived
