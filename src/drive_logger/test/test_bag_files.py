"""Bag layout, definitions and damaged-bag handling, without a ROS graph."""
import subprocess
import sys
import time

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
    code = ('import sys\nimport drive_logger.bag_writer, drive_logger.bag_reader, drive_logger.qos_yaml\n'
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
