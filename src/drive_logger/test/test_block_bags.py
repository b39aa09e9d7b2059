"""Block bags downstream: per-sample expansion, third-party readers, bag info, replay
with expand_blocks and compare_replay, on bags written from a headless run (no graph needed
to make them)."""
import argparse
import threading

import numpy as np
import pytest
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message

from drive_common.waiting import wait_until
from drive_logger.bag_reader import BagReader
from drive_logger.block_topics import per_sample_messages
from drive_common.cdr_padding import canonicalize
from drive_logger.ros_types import message_class
from drive_testing.block_bags import scenario_bags

SCENARIO = 'two_phase_six_switch_torque_step'
DURATION = 0.012      # s: 360 controller samples, the runtime torque step at 9.4 ms included
PER_SAMPLE_TOPICS = ('/plant/state', '/dtc/status', '/drive/measurement', '/drive/gate_command')


@pytest.fixture(scope='module')
def run(tmp_path_factory):
    return scenario_bags(SCENARIO, DURATION, tmp_path_factory.mktemp('blocks'))


def _by_topic(messages):
    """{topic: [(log time, CDR bytes with zeroed padding)]} (rclpy leaves padding uninitialised)."""
    out = {}
    for msg in messages:
        out.setdefault(msg.topic, []).append((msg.log_time, canonicalize(msg.data, message_class(msg.type))))
    return out


def test_expanded_blocks_are_the_per_sample_messages_bit_exact(run):
    _, bags = run
    expected = _by_topic(BagReader(bags['per_sample']).messages(PER_SAMPLE_TOPICS))
    got = _by_topic(per_sample_messages(BagReader(bags['blocks']), PER_SAMPLE_TOPICS))
    assert set(got) == set(PER_SAMPLE_TOPICS) == set(expected)
    for topic in PER_SAMPLE_TOPICS:   # every sample, same bytes, logged at its stamp (sim log times)
        assert got[topic] == expected[topic], topic
    # all topics: the blocks replaced by their samples, in log-time order
    everything = list(per_sample_messages(BagReader(bags['blocks'])))
    assert not any(m.topic.endswith('_block') for m in everything)
    assert [m.log_time for m in everything] == sorted(m.log_time for m in everything)
    status = _by_topic(m for m in everything if m.topic == '/dtc/status')['/dtc/status']
    assert sorted(status) == expected['/dtc/status']
    assert [m.topic for m in everything].count('/parameter_events') == 1


def test_third_party_readers_decode_every_message_of_a_block_bag(run):
    """rosbags (its rosbag2 reader and a type store of the bag's own definitions) and the mcap
    ROS 2 decoder read every message, block fields equal to ours."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from rosbags.highlevel import AnyReader
    from drive_logger.ros_types import message_class
    _, bags = run
    ours = list(BagReader(bags['blocks']).messages())
    assert {'/plant/state_block', '/dtc/status_block'} <= {m.topic for m in ours}

    def check(topic, type_name, decoded, data):
        msg = deserialize_message(data, message_class(type_name))
        if topic == '/parameter_events':
            assert decoded.changed_parameters[0].name == msg.changed_parameters[0].name == 'torque_reference'
            return
        if topic.endswith('_block'):
            assert (decoded.first_step, decoded.count) == (msg.first_step, msg.count)
            field = 'phase_current' if 'state' in topic else 'measurement_phase_current'
            assert (np.asarray(getattr(decoded, field), dtype=np.float64).tobytes()
                    == np.asarray(getattr(msg, field), dtype=np.float64).tobytes())
        assert decoded.header.stamp.sec == msg.header.stamp.sec
        assert decoded.header.stamp.nanosec == msg.header.stamp.nanosec

    with AnyReader([bags['blocks']]) as reader:
        third = [(c.topic, c.msgtype, reader.deserialize(raw, c.msgtype), raw) for c, _, raw in reader.messages()]
    assert len(third) == len(ours)
    for topic, type_name, decoded, raw in third:
        check(topic, type_name, decoded, raw)
    (data_file,) = bags['blocks'].glob('*.mcap')
    with open(data_file, 'rb') as f:
        mcap = [(c.topic, s.name, d, m.data) for s, c, m, d in
                make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages()]
    assert len(mcap) == len(ours)
    for topic, type_name, decoded, raw in mcap:
        check(topic, type_name, decoded, raw)


def test_bag_info_shows_block_samples_and_step_gaps(run, tmp_path, capsys):
    from drive_logger.bag_writer import BagWriter
    from drive_logger.message_definitions import type_definition
    from drive_ros2cli.verbs.bag import info_main
    _, bags = run
    per_sample = BagReader(bags['per_sample']).topics
    assert info_main(argparse.Namespace(bag_path=str(bags['blocks']))) == 0
    out = capsys.readouterr().out
    state = [line for line in out.splitlines() if 'Topic: /plant/state_block ' in line]
    status = [line for line in out.splitlines() if 'Topic: /dtc/status_block ' in line]
    assert state and state[0].endswith(f'| Samples: {per_sample["/plant/state"].message_count}')
    assert status and status[0].endswith(f'| Samples: {per_sample["/dtc/status"].message_count}')
    # the viewer topic beside its block: its samples of the block's
    viewer = [line for line in out.splitlines() if 'Topic: /plant/state ' in line]
    shown = BagReader(bags['blocks']).topics['/plant/state'].message_count
    assert viewer and viewer[0].endswith(
        f'| Samples: {shown} of {per_sample["/plant/state"].message_count} in /plant/state_block')
    assert 'Block steps' not in out
    # one block of /dtc/status_block repeated: reported
    reader = BagReader(bags['blocks'])
    with BagWriter(tmp_path / 'repeat') as writer:
        records = {n: writer.add_topic(n, type_definition(i.type), i.qos_profiles) for n, i in reader.topics.items()}
        repeated = False
        for msg in reader.messages():
            writer.write(records[msg.topic], msg.data, msg.log_time, msg.publish_time)
            if msg.topic == '/dtc/status_block' and not repeated and msg.log_time > 1_000_000:
                writer.write(records[msg.topic], msg.data, msg.log_time, msg.publish_time)
                repeated = True
    assert info_main(argparse.Namespace(bag_path=str(tmp_path / 'repeat'))) == 0
    out = capsys.readouterr().out
    assert 'Block steps:' in out and '/dtc/status_block: steps repeated' in out


@pytest.mark.ros
def test_replay_expand_blocks_publishes_the_per_sample_messages(run, ros_session, start_node):
    from dtc_msgs.msg import DriveMeasurement, DtcStatus, DtcStatusBlock, GateCommand, PlantState
    _, bags = run
    expected = _by_topic(BagReader(bags['per_sample']).messages(PER_SAMPLE_TOPICS))
    node = ros_session.node('listener')
    got = {t: [] for t in PER_SAMPLE_TOPICS}
    lock = threading.Lock()
    deep = QoSProfile(depth=5000, reliability=ReliabilityPolicy.RELIABLE)
    types = dict(zip(PER_SAMPLE_TOPICS, (PlantState, DtcStatus, DriveMeasurement, GateCommand)))
    for topic, cls in types.items():
        def take(data, topic=topic, name=f'dtc_msgs/msg/{cls.__name__}'):
            with lock:
                got[topic].append(canonicalize(data, message_class(name)))
        node.create_subscription(cls, topic, take, deep, raw=True)
    blocks = []
    node.create_subscription(DtcStatusBlock, '/dtc/status_block',
                             blocks.append, deep, raw=True)
    start_node('drive_logger', 'replay', parameters={
        'bag': str(bags['blocks']), 'rate': 0.5, 'expand_blocks': True, 'wait_for_subscribers': 20.0,
        'topics': list(PER_SAMPLE_TOPICS)})
    total = sum(len(v) for v in expected.values())
    wait_until(lambda: sum(len(v) for v in got.values()) >= total, 60.0, raise_timeout=False)
    assert {t: len(v) for t, v in got.items()} == {t: len(v) for t, v in expected.items()}
    for topic in PER_SAMPLE_TOPICS:
        assert got[topic] == [data for _, data in expected[topic]], topic
    assert blocks == []     # the blocks themselves are not re-published


@pytest.mark.ros
def test_compare_replay_on_a_block_bag_passes_and_catches_a_changed_parameter(run, ros_session):
    from drive_testing.harness import NodeProcess, isolated_env
    from drive_logger.compare_replay import replay_and_compare
    scenario, bags = run
    parameters = dict(scenario.node_parameters['dtc_controller'])
    samples = BagReader(bags['per_sample']).topics['/drive/measurement'].message_count
    reports = {}
    for label, changes in (('same', {}), ('changed', {'torque_band': 0.05})):
        controller = NodeProcess('dtc_controller', 'dtc_controller', parameters=parameters | changes,
                                 env=isolated_env(ros_session.domain_id))
        try:
            reports[label] = replay_and_compare(str(bags['blocks']), controller, context=ros_session.context)
        finally:
            controller.stop()
    same, changed = reports['same'], reports['changed']
    assert same.parameter_changes == 1      # the torque step, re-applied where the original took it
    assert same.steps_compared == samples and same.identical and same.matching == samples
    assert not changed.identical and changed.mismatch_count > 0     # (a late reply may go missing here)
