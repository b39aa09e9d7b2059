"""Bag layout, definitions and damaged-bag handling, without a ROS graph."""
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from rclpy.serialization import serialize_message

from drive_logger import qos_yaml
from drive_logger.bag_reader import BagReadError, BagReader
from drive_logger.bag_writer import BagWriteError, BagWriter
from drive_logger.message_definitions import DELIMITER, dependencies, interface_file, type_definition


def test_schema_text_has_dependencies_depth_first_once():
    text = type_definition('dtc_msgs/msg/PlantState').text
    root = interface_file('dtc_msgs/msg/PlantState').read_text()
    header = interface_file('std_msgs/msg/Header').read_text()
    time_ = interface_file('builtin_interfaces/msg/Time').read_text()
    expected = (root + f'\n{DELIMITER}\nMSG: std_msgs/Header\n' + header
                + f'\n{DELIMITER}\nMSG: builtin_interfaces/Time\n' + time_)
    assert text == expected
    assert text.count('MSG: ') == 2


def test_dependencies_are_sorted_and_skip_primitives_and_constants():
    text = 'uint8 X = 4\nHeader header\nfoo/Bar[3] a  # c\nLocal<=2 b\nstring<=5 s\nbuiltin_interfaces/msg/Time t\n'
    assert dependencies(text, 'pkg') == ['builtin_interfaces/Time', 'foo/Bar', 'pkg/Local', 'std_msgs/Header']


def test_type_hash_comes_from_installed_json():
    import json
    data = json.loads(interface_file('dtc_msgs/msg/GateCommand', '.json').read_text())
    expected = [h['hash_string'] for h in data['type_hashes'] if h['type_name'] == 'dtc_msgs/msg/GateCommand'][0]
    assert type_definition('dtc_msgs/GateCommand').type_hash == expected
    assert expected.startswith('RIHS01_')


def test_core_modules_do_not_import_rclpy():
    code = ('import sys\nimport drive_logger.bag_writer, drive_logger.bag_reader, drive_logger.bag_reindex, drive_logger.qos_yaml\n'
            'import drive_logger.message_definitions\n'
            'assert "rclpy" not in sys.modules, "rclpy imported"\n')
    subprocess.run([sys.executable, '-c', code], check=True)


def test_existing_or_unwritable_output_is_refused(tmp_path):
    (tmp_path / 'taken').mkdir()
    with pytest.raises(BagWriteError, match='already exists'):
        BagWriter(tmp_path / 'taken')
    (tmp_path / 'afile').write_text('x')
    with pytest.raises(BagWriteError, match='not writable'):
        BagWriter(tmp_path / 'afile' / 'bag')
    assert not (tmp_path / 'afile' / 'bag').exists()


def _write_bag(path, count, measurement_factory, chunk_size=4096):
    writer = BagWriter(path, chunk_size=chunk_size)
    topic = writer.add_topic('/drive/measurement', type_definition('dtc_msgs/msg/DriveMeasurement'),
                             [qos_yaml.profile()])
    for k in range(count):
        writer.write(topic, serialize_message(measurement_factory(k)), time.time_ns(), time.time_ns())
    return writer


def test_metadata_matches_channels_and_rosbags_reads_it(tmp_path, measurement_factory):
    _write_bag(tmp_path / 'bag', 300, measurement_factory).close()
    meta = yaml.safe_load((tmp_path / 'bag' / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert meta['version'] == 9 and meta['storage_identifier'] == 'mcap'
    assert meta['relative_file_paths'] == ['bag_0.mcap']
    entry = meta['topics_with_message_count'][0]
    assert entry['message_count'] == 300 == meta['message_count']
    from mcap.reader import make_reader
    with open(tmp_path / 'bag' / 'bag_0.mcap', 'rb') as f:
        reader = make_reader(f)
        header, summary = reader.get_header(), reader.get_summary()
        (channel,) = summary.channels.values()
        assert header.profile == 'ros2'
        assert summary.schemas[channel.schema_id].encoding == 'ros2msg'
        assert channel.message_encoding == 'cdr'
        assert qos_yaml.load(channel.metadata['offered_qos_profiles']) == entry['topic_metadata']['offered_qos_profiles']
        assert channel.metadata['topic_type_hash'] == entry['topic_metadata']['type_description_hash']
        (record,) = [m for m in reader.iter_metadata() if m.name == 'rosbag2']
        assert yaml.safe_load(record.metadata['serialized_metadata'])['message_count'] == 300
    from rosbags.highlevel import AnyReader
    with AnyReader([tmp_path / 'bag']) as reader:
        steps = [reader.deserialize(raw, c.msgtype).step for c, _, raw in reader.messages()]
    assert steps == list(range(300))


def test_truncated_bag_is_a_clear_error_and_salvage_reads_the_intact_part(tmp_path, measurement_factory):
    writer = _write_bag(tmp_path / 'bag', 500, measurement_factory)
    writer._stream.flush()  # simulate a crash: no close(), no footer, no metadata.yaml
    size = (tmp_path / 'bag' / 'bag_0.mcap').stat().st_size
    with pytest.raises(BagReadError, match='metadata.yaml.*truncated|truncated') as err:
        BagReader(tmp_path / 'bag')
    assert 'salvage' in str(err.value) and 'no MCAP footer' in str(err.value)
    reader = BagReader(tmp_path / 'bag', salvage=True)
    steps = [reader.decode(m).step for m in reader.messages()]
    assert 0 < len(steps) < 500 and steps == list(range(len(steps)))
    # cut in the middle of a chunk of the finalized file: still a clear error
    writer.close()
    data = (tmp_path / 'bag' / 'bag_0.mcap').read_bytes()
    (tmp_path / 'bag' / 'bag_0.mcap').write_bytes(data[:size // 2])
    with pytest.raises(BagReadError, match='truncated'):
        BagReader(tmp_path / 'bag')


def test_corrupt_chunk_is_a_clear_error(tmp_path, measurement_factory):
    _write_bag(tmp_path / 'bag', 500, measurement_factory).close()
    path = tmp_path / 'bag' / 'bag_0.mcap'
    data = bytearray(path.read_bytes())
    data[len(data) // 3: len(data) // 3 + 64] = b'\xff' * 64
    path.write_bytes(bytes(data))
    with pytest.raises(BagReadError, match='corrupt'):
        list(BagReader(tmp_path / 'bag').messages())
    salvaged = [m for m in BagReader(tmp_path / 'bag', salvage=True).messages()]
    assert 0 < len(salvaged) < 500


def _stamped_bag(path, measurement_factory, flushed, unflushed, chunk_size=1 << 20):
    """A sim-time bag: `flushed` messages flushed to disk, then `unflushed` more left in the open chunk
    (the state a SIGKILL leaves). Returns (writer, published CDR bytes, the file's bytes at the last flush)."""
    from drive_logger.message_definitions import cdr_stamp_ns
    writer = BagWriter(path, chunk_size=chunk_size)
    topic = writer.add_topic('/drive/measurement', type_definition('dtc_msgs/msg/DriveMeasurement'),
                             [qos_yaml.profile()])
    sent = []
    for k in range(flushed + unflushed):
        data = serialize_message(measurement_factory(k))
        writer.write(topic, data, cdr_stamp_ns(data), cdr_stamp_ns(data))
        sent.append(data)
        if k + 1 == flushed // 2 or k + 1 == flushed:
            writer.flush()
            on_disk = writer.data_file.read_bytes()
    return writer, sent, on_disk


def test_sim_time_bag_metadata_and_summary_agree(tmp_path, measurement_factory):
    writer, sent, _ = _stamped_bag(tmp_path / 'bag', measurement_factory, 100, 20)
    writer.close()
    meta = yaml.safe_load((tmp_path / 'bag' / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert meta['custom_data'] == {'log_time': 'sim'}
    assert meta['starting_time']['nanoseconds_since_epoch'] == 0                 # sample 0 at t = 0
    assert meta['duration']['nanoseconds'] == 119 * 25_000                       # 119 samples of 25 us
    assert meta['files'][0]['duration'] == meta['duration']
    from mcap.reader import make_reader
    with open(tmp_path / 'bag' / 'bag_0.mcap', 'rb') as f:
        stats = make_reader(f).get_summary().statistics
    assert (stats.message_start_time, stats.message_end_time, stats.message_count) == (0, 119 * 25_000, 120)
    assert BagReader(tmp_path / 'bag').log_time_source == 'sim'


def _read_all_three_ways(bag):
    """(topic, log_time, data) per reader: rosbags.rosbag2.Reader, the mcap ROS 2 reader, BagReader."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from rosbags.rosbag2 import Reader
    with Reader(bag) as reader:
        by_rosbags = [(c.topic, t, bytes(raw)) for c, t, raw in reader.messages()]
    (data_file,) = bag.glob('*.mcap')
    with open(data_file, 'rb') as f:
        decoded = [(c.topic, m.log_time, m.data, d) for _, c, m, d in
                   make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages()]
    assert all(d.step is not None for *_, d in decoded)
    by_mcap = [(t, lt, bytes(data)) for t, lt, data, _ in decoded]
    by_ours = [(m.topic, m.log_time, m.data) for m in BagReader(bag).messages()]
    return by_rosbags, by_mcap, by_ours


def test_reindex_completes_a_killed_bag_with_the_flushed_messages_only(tmp_path, measurement_factory):
    import shutil
    from drive_logger.bag_reindex import main, reindex
    from drive_logger.message_definitions import cdr_stamp_ns
    writer, sent, flushed = _stamped_bag(tmp_path / 'live', measurement_factory, 200, 57)
    # The killed recorder's directory: the file as it was at the last flush, plus half of a record
    # being written after it (the later file's bytes there: the open chunk, grown).
    writer.flush()
    data = (tmp_path / 'live' / 'live_0.mcap').read_bytes()
    assert len(data) > len(flushed)
    bag = tmp_path / 'bag'
    bag.mkdir()
    cut = flushed + data[len(flushed):len(flushed) + (len(data) - len(flushed)) // 2]
    (bag / 'bag_0.mcap').write_bytes(cut)
    with pytest.raises(BagReadError, match='no MCAP footer'):
        BagReader(bag)
    assert BagReader(bag, salvage=True).log_time_source == 'sim'   # from the record after the header

    summary = reindex(bag)
    assert summary.rewritten and summary.message_count == 200
    assert summary.topics == {'/drive/measurement': 200}
    assert summary.kept_aside == bag / 'bag_0.mcap.orig' and summary.kept_aside.read_bytes() == cut
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert meta['message_count'] == 200 == meta['topics_with_message_count'][0]['message_count']
    assert meta['relative_file_paths'] == ['bag_0.mcap'] and meta['custom_data'] == {'log_time': 'sim'}
    assert meta['duration']['nanoseconds'] == 199 * 25_000
    expected = [('/drive/measurement', cdr_stamp_ns(d), d) for d in sent[:200]]   # nothing invented
    for got in _read_all_three_ways(bag):
        assert got == expected
    # metadata.yaml's QoS equals the channel's, so rosbags keeps the topic; the rest survives unchanged
    assert BagReader(bag).topics['/drive/measurement'].qos_profiles == [qos_yaml.profile()]

    again = reindex(bag)     # complete now: left alone
    assert not again.rewritten and again.message_count == 200
    shutil.copy(bag / 'bag_0.mcap.orig', bag / 'bag_0.mcap')
    (bag / 'metadata.yaml').unlink()
    assert main([str(bag)]) == 0
    assert (bag / 'bag_0.mcap.orig.1').read_bytes() == cut
    assert [m.data for m in BagReader(bag).messages()] == sent[:200]


def test_a_kill_cutting_the_open_chunk_rewrite_keeps_the_flushed_messages_from_beside_the_file(
        tmp_path, measurement_factory):
    import struct
    from drive_logger.bag_reindex import reindex
    writer, sent, flushed = _stamped_bag(tmp_path / 'live', measurement_factory, 200, 57)
    writer.flush()                  # all 257 in the open chunk, rewritten in place
    live = tmp_path / 'live' / 'live_0.mcap'
    data, journal = live.read_bytes(), Path(f'{live}.open-chunk').read_bytes()
    offset = struct.unpack_from('<Q', journal)[0]
    assert data[offset:] == journal[8:] and offset < len(flushed)     # where the 200 were
    for name, cut, kept in (('rewrite', data[:offset + (len(data) - offset) // 2], 257),   # cut in the rewrite
                            ('after', flushed + b'\x06' + bytes(40), 200)):   # intact to a later cut: not used
        bag = tmp_path / name
        bag.mkdir()
        (bag / 'bag_0.mcap').write_bytes(cut)
        (bag / 'bag_0.mcap.open-chunk').write_bytes(journal)
        assert [m.data for m in BagReader(bag, salvage=True).messages()] == sent[:kept], name
        assert reindex(bag).message_count == kept
        assert [m.data for m in BagReader(bag).messages()] == sent[:kept], name
    writer.close()
    assert not Path(f'{live}.open-chunk').exists()


def test_reindex_of_a_malformed_bag_is_a_one_line_error(tmp_path, capsys):
    from drive_logger.bag_reindex import main
    assert main([str(tmp_path / 'nope')]) == 2
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and 'nope' in err and 'does not exist' in err
    (tmp_path / 'bad').mkdir()
    (tmp_path / 'bad' / 'bad_0.mcap').write_bytes(b'not an mcap file at all')
    assert main([str(tmp_path / 'bad')]) == 2
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and 'bad_0.mcap' in err and 'not an MCAP file' in err and 'Traceback' not in err
    assert sorted(p.name for p in (tmp_path / 'bad').iterdir()) == ['bad_0.mcap']    # untouched
    assert main([]) == 2 and 'usage' in capsys.readouterr().err


def test_writer_refuses_the_directory_of_a_killed_recorder_naming_reindex(tmp_path, measurement_factory):
    writer, _, _ = _stamped_bag(tmp_path / 'bag', measurement_factory, 10, 0)
    writer._stream.flush()
    with pytest.raises(BagWriteError, match='never finalized.*drive_logger reindex'):
        BagWriter(tmp_path / 'bag')


def test_which_types_carry_their_sample_sim_time():
    from drive_logger.message_definitions import carries_sim_stamp, cdr_stamp_ns
    from drive_logger.graph_topics import GRAPH_TOPIC_TYPES
    # every drive-graph type, also those whose .msg starts with constants (GateCommand, PlantState)
    assert all(carries_sim_stamp(t) for t in GRAPH_TOPIC_TYPES.values())
    # stamped by the publishing node: not the sim time of a sample
    assert not carries_sim_stamp('rcl_interfaces/msg/ParameterEvent')
    assert not carries_sim_stamp('rcl_interfaces/msg/Log')
    from drive_logger.message_definitions import (NO_STAMP, NODE_STAMP, SAMPLE_STAMP, is_sim_stamp,
                                                  sim_stamp_kind)
    assert sim_stamp_kind('dtc_msgs/msg/GateCommand') == sim_stamp_kind('rosgraph_msgs/Clock') == SAMPLE_STAMP
    assert sim_stamp_kind('rcl_interfaces/ParameterEvent') == NODE_STAMP   # sim from drive nodes
    assert sim_stamp_kind('rcl_interfaces/msg/Log') == sim_stamp_kind('std_msgs/msg/String') == NO_STAMP
    assert is_sim_stamp(0) and is_sim_stamp(3_600 * 10**9) and not is_sim_stamp(-1)
    assert not is_sim_stamp(1_795_000_000 * 10**9)                      # a wall clock
    from dtc_msgs.msg import GateCommand
    from rosgraph_msgs.msg import Clock
    gate = GateCommand(step=7)
    gate.header.stamp.sec, gate.header.stamp.nanosec = 2, 5
    assert cdr_stamp_ns(serialize_message(gate)) == 2_000_000_005
    assert cdr_stamp_ns(serialize_message(Clock(clock=gate.header.stamp))) == 2_000_000_005


def test_wall_stamped_messages_wait_for_the_sim_time_their_wake_up_reached(tmp_path, measurement_factory):
    from drive_logger.bag_writer import SimTimeLog
    from drive_logger.message_definitions import NO_STAMP, NODE_STAMP, SAMPLE_STAMP
    from rcl_interfaces.msg import ParameterEvent
    from std_msgs.msg import String
    writer = BagWriter(tmp_path / 'bag')
    meas = writer.add_topic('/drive/measurement', type_definition('dtc_msgs/msg/DriveMeasurement'))
    events = writer.add_topic('/parameter_events', type_definition('rcl_interfaces/msg/ParameterEvent'))
    notes = writer.add_topic('/notes', type_definition('std_msgs/msg/String'))
    log = SimTimeLog(writer)
    wall = ParameterEvent(node='/recorder')
    wall.stamp.sec = 1_795_000_000                          # a wall clock: not used
    sim = ParameterEvent(node='/dtc_controller')
    sim.stamp.nanosec = 50_000                              # a drive node's sim stamp: logged there
    log.write(meas, serialize_message(measurement_factory(3)), SAMPLE_STAMP)
    log.write(events, serialize_message(wall), NODE_STAMP)   # taken before sample 4 in this wake-up
    log.write(events, serialize_message(sim), NODE_STAMP)
    log.write(meas, serialize_message(measurement_factory(4)), SAMPLE_STAMP)
    log.end_of_wakeup()
    log.write(notes, serialize_message(String(data='x')), NO_STAMP)
    log.end_of_wakeup()
    writer.close()
    times = [(m.topic, m.log_time, m.publish_time) for m in BagReader(tmp_path / 'bag').messages()]
    assert sorted(times) == sorted([('/drive/measurement', 75_000, 75_000), ('/drive/measurement', 100_000, 100_000),
                                    ('/parameter_events', 50_000, 50_000), ('/parameter_events', 100_000, 100_000),
                                    ('/notes', 100_000, 100_000)])


def test_the_drive_topics_that_tell_a_namespace_are_the_drive_graphs():
    from drive_common import topics as names
    from drive_logger.bag_reader import DRIVE_TOPICS
    assert set(DRIVE_TOPICS) == {'/' + t for t in (
        names.PLANT_STATE_BLOCK, names.DTC_STATUS_BLOCK, names.PFC_STATUS_BLOCK, names.PLANT_STATE,
        names.DTC_STATUS, names.PFC_STATUS, names.DRIVE_MEASUREMENT, names.GATE_COMMAND,
        names.PFC_MEASUREMENT, names.DUTY_COMMAND)}
