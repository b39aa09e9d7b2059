"""Recorder node as a process: field-exact read-back by two independent readers, SIGINT, bad input."""
import math
import os
import signal
import threading
import time

import pytest
import yaml

from drive_common.waiting import wait_until
from drive_common.topics import DRIVE_MEASUREMENT, GATE_COMMAND, LOCKSTEP_QOS
from drive_logger.readiness import wait_for_recorder
from dtc_msgs.msg import DriveMeasurement, GateCommand

pytestmark = pytest.mark.ros
TOPICS = ['/drive/measurement', '/drive/gate_command']


def _same(a, b) -> bool:
    return a == b or (isinstance(a, float) and math.isnan(a) and math.isnan(b))


def _assert_fields(published, decoded):
    """Field-exact comparison of a published rclpy message and a third-party decoded one."""
    assert decoded.step == published.step
    assert decoded.header.stamp.sec == published.header.stamp.sec
    assert decoded.header.stamp.nanosec == published.header.stamp.nanosec
    for name in published.get_fields_and_field_types():
        if name == 'header':
            continue
        a, b = getattr(published, name), getattr(decoded, name)
        if hasattr(a, '__len__') and not isinstance(a, str):
            assert len(a) == len(b) and all(_same(x, y) for x, y in zip(list(a), list(b))), name
        else:
            assert _same(a, b), name


def _start_recorder(start_node, output, topics=TOPICS, **extra):
    return start_node('drive_logger', 'recorder', parameters={'output': str(output), 'topics': topics, **extra})


def _all_received(*publishers, timeout: float = 30.0) -> None:
    """Wait until every matched reader (the recorder's) acknowledged all that publishers sent (reliable QoS)."""
    from rclpy.duration import Duration
    for pub in publishers:
        assert pub.wait_for_all_acked(Duration(seconds=timeout)), f'{pub.topic_name}: not all acknowledged'


def _stop(process, sig=signal.SIGINT, timeout=15.0) -> int:
    os.killpg(process.pid, sig)
    return process.process.wait(timeout=timeout)


def _record_measurements(ros_session, start_node, bag):
    """A recorder of drive/measurement into bag, matched with a new publisher: (recorder, publisher)."""
    recorder = _start_recorder(start_node, bag, topics=['drive/measurement'])
    node = ros_session.node('publisher')
    pub = node.create_publisher(DriveMeasurement, DRIVE_MEASUREMENT, LOCKSTEP_QOS)
    wait_for_recorder(node, ['drive/measurement'], timeout=20.0)
    return recorder, pub


def test_recorded_bag_reads_back_field_exact(ros_session, start_node, tmp_path, measurement_factory):
    bag = tmp_path / 'bag'
    recorder = _start_recorder(start_node, bag)
    node = ros_session.node('publisher')
    meas_pub = node.create_publisher(DriveMeasurement, DRIVE_MEASUREMENT, LOCKSTEP_QOS)
    gate_pub = node.create_publisher(GateCommand, GATE_COMMAND, LOCKSTEP_QOS)
    wait_for_recorder(node, TOPICS, timeout=20.0)
    published = {'/drive/measurement': [], '/drive/gate_command': []}
    for k in range(2000):
        meas = measurement_factory(k)
        gate = GateCommand(step=k, topology=6 - 2 * (k % 2), switch_on=[bool((k >> n) & 1) for n in range(6)])
        gate.header.stamp = meas.header.stamp
        meas_pub.publish(meas)
        gate_pub.publish(gate)
        published['/drive/measurement'].append(meas)
        published['/drive/gate_command'].append(gate)
        if k % 50 == 0:
            time.sleep(0.002)  # lockstep-like pacing; the recorder must keep up, nothing dropped
    _all_received(meas_pub, gate_pub)
    assert _stop(recorder) == 0, recorder.output()

    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    counts = {e['topic_metadata']['name']: e['message_count'] for e in meta['topics_with_message_count']}
    assert counts == {t: 2000 for t in TOPICS}
    for entry in meta['topics_with_message_count']:
        qos = entry['topic_metadata']['offered_qos_profiles']
        assert qos and qos[0]['reliability'] == 'reliable'
        assert entry['topic_metadata']['type_description_hash'].startswith('RIHS01_')

    # reader 1: rosbags
    from rosbags.highlevel import AnyReader
    got = {t: [] for t in TOPICS}
    with AnyReader([bag]) as reader:
        assert {c.topic for c in reader.connections} == set(TOPICS)  # no topic dropped for a QoS mismatch
        for conn, _, raw in reader.messages():
            got[conn.topic].append(reader.deserialize(raw, conn.msgtype))
    for topic in TOPICS:
        assert [m.step for m in got[topic]] == list(range(2000))
        for pub, dec in zip(published[topic], got[topic]):
            _assert_fields(pub, dec)

    # reader 2: mcap + mcap-ros2-support, straight from the .mcap file
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    got = {t: [] for t in TOPICS}
    with open(bag / 'bag_0.mcap', 'rb') as f:
        for _, channel, _, decoded in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            got[channel.topic].append(decoded)
    for topic in TOPICS:
        assert len(got[topic]) == 2000
        for pub, dec in zip(published[topic], sorted(got[topic], key=lambda m: m.step)):
            _assert_fields(pub, dec)

    # the bytes in the bag are the publisher's wire bytes: rclpy decodes them to the very messages
    from rclpy.serialization import deserialize_message
    from drive_logger.bag_reader import BagReader
    for msg, pub in zip(BagReader(bag).messages(['/drive/gate_command']), published['/drive/gate_command']):
        assert deserialize_message(msg.data, GateCommand) == pub


def test_messages_from_other_publishers_are_recorded_in_canonical_cdr(ros_session, start_node, tmp_path):
    """rclpy publishes a ParameterEvent with uninitialised padding and, after an empty int64[] or
    float64[], bytes past its last field, which rosbags refuses; the recorder writes every such
    message as canonical CDR (the values' bits, zero padding, exact length), so the same values
    give the same bytes and every reader decodes the bag."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from rcl_interfaces.msg import Parameter, ParameterEvent, ParameterValue
    from rclpy.serialization import serialize_message
    from rosbags.highlevel import AnyReader

    from drive_common.cdr_padding import serialize_zero_padded
    from drive_logger.bag_reader import BagReader

    bag = tmp_path / 'bag'
    recorder = _start_recorder(start_node, bag, topics=['/probe/events:rcl_interfaces/msg/ParameterEvent',
                                                        '/diagnostics'])
    node = ros_session.node('publisher')
    event_pub = node.create_publisher(ParameterEvent, '/probe/events', 100)
    diagnostics_pub = node.create_publisher(DiagnosticArray, '/diagnostics', 100)
    wait_for_recorder(node, ['/probe/events', '/diagnostics'], timeout=20.0)
    wait_until(lambda: event_pub.get_subscription_count() and diagnostics_pub.get_subscription_count(), 20.0,
               what='the recorder matched')
    events = [ParameterEvent(node='/probe', changed_parameters=[
        Parameter(name=f'p{k}', value=ParameterValue(type=3, double_value=k / 3.0))]) for k in range(20)]
    diagnostics = [DiagnosticArray(status=[DiagnosticStatus(level=bytes([k % 3]), name='probe', message=f'm{k}',
                                                            values=[KeyValue(key='k', value=str(k))])])
                   for k in range(20)]
    assert any(serialize_message(e) != serialize_zero_padded(e) for e in events)   # what is at stake
    for event, status in zip(events, diagnostics):
        event_pub.publish(event)
        diagnostics_pub.publish(status)
    _all_received(event_pub, diagnostics_pub)
    assert _stop(recorder) == 0, recorder.output()

    recorded = {}
    for msg in BagReader(bag).messages():
        recorded.setdefault(msg.topic, []).append(msg.data)
    assert recorded['/probe/events'] == [serialize_zero_padded(e) for e in events]
    assert recorded['/diagnostics'] == [serialize_zero_padded(d) for d in diagnostics]
    with AnyReader([bag]) as reader:
        decoded = [(c.topic, reader.deserialize(raw, c.msgtype)) for c, _, raw in reader.messages()]
    assert [m.changed_parameters[0].value.double_value for t, m in decoded if t == '/probe/events'] == \
        [k / 3.0 for k in range(20)]
    assert [m.status[0].message for t, m in decoded if t == '/diagnostics'] == [f'm{k}' for k in range(20)]


def test_parameter_declarations_are_left_out_and_changes_recorded(ros_session, start_node, tmp_path):
    """A node declares its parameters as it starts, before or after a recorder has matched it
    depending on discovery timing: declaration-only events are not recorded, so two recordings
    of one scenario are the same bag; changes and deletions are."""
    from rcl_interfaces.msg import Parameter, ParameterEvent, ParameterValue

    from drive_common.cdr_padding import serialize_zero_padded
    from drive_logger.bag_reader import BagReader

    bag = tmp_path / 'bag'
    recorder = _start_recorder(start_node, bag, topics=['/parameter_events'])
    node = ros_session.node('publisher')
    event_pub = node.create_publisher(ParameterEvent, '/parameter_events', 100)
    wait_for_recorder(node, ['/parameter_events'], timeout=20.0)
    wait_until(lambda: event_pub.get_subscription_count(), 20.0, what='the recorder matched')

    def param(k):
        return [Parameter(name=f'p{k}', value=ParameterValue(type=3, double_value=float(k)))]

    declared = [ParameterEvent(node='/probe', new_parameters=param(k)) for k in range(5)]
    kept = [ParameterEvent(node='/probe', changed_parameters=param(1)),
            ParameterEvent(node='/probe', new_parameters=param(7), changed_parameters=param(2)),
            ParameterEvent(node='/probe', deleted_parameters=param(3))]
    for event in declared[:3] + kept[:2] + declared[3:] + kept[2:]:
        event_pub.publish(event)
    _all_received(event_pub)
    assert _stop(recorder) == 0, recorder.output()
    recorded = [msg.data for msg in BagReader(bag).messages(['/parameter_events'])]
    assert recorded == [serialize_zero_padded(e) for e in kept]


def test_sigint_mid_run_keeps_every_message_up_to_the_stop(ros_session, start_node, tmp_path, measurement_factory):
    bag = tmp_path / 'bag'
    recorder, pub = _record_measurements(ros_session, start_node, bag)
    stop_publishing = threading.Event()
    published = [0]

    def publish():
        while not stop_publishing.is_set():
            pub.publish(measurement_factory(published[0]))
            published[0] += 1
            time.sleep(0.0005)

    thread = threading.Thread(target=publish)
    thread.start()
    try:
        wait_until(lambda: published[0] >= 1000, 60.0, what='the run under way')
        at_signal = published[0]
        os.killpg(recorder.pid, signal.SIGINT)   # mid-run: the publisher keeps going
        wait_until(lambda: published[0] >= at_signal + 200, 60.0, what='publishing after the signal')
    finally:
        stop_publishing.set()
        thread.join()
    assert recorder.process.wait(timeout=15) == 0, recorder.output()
    from drive_logger.bag_reader import BagReader
    reader = BagReader(bag)   # finalized: opens without salvage
    steps = [reader.decode(m).step for m in reader.messages()]
    assert len(steps) > 500
    assert steps == list(range(len(steps))), 'gap in the recorded steps'
    assert reader.topics['/drive/measurement'].message_count == len(steps)


def test_sigterm_finalizes_too(ros_session, start_node, tmp_path, measurement_factory):
    bag = tmp_path / 'bag'
    recorder, pub = _record_measurements(ros_session, start_node, bag)
    for k in range(100):
        pub.publish(measurement_factory(k))
    _all_received(pub)
    assert _stop(recorder, signal.SIGTERM) == 0
    from drive_logger.bag_reader import BagReader
    # sim-time log times (the default): each message at its header stamp, sample k at k * 25 us
    assert [(m.log_time, m.publish_time) for m in BagReader(bag).messages()] == [(k * 25_000,) * 2 for k in range(100)]


def test_wall_log_times_and_flushed_messages_survive_sigkill(ros_session, start_node, tmp_path, measurement_factory):
    from drive_testing.harness import wait_until
    from drive_logger.bag_reader import BagReader, intact_messages
    from drive_logger.bag_reindex import reindex
    bag = tmp_path / 'bag'
    recorder = _start_recorder(start_node, bag, topics=['drive/measurement'], log_time='wall', flush_period=0.2)
    node = ros_session.node('publisher')
    pub = node.create_publisher(DriveMeasurement, DRIVE_MEASUREMENT, LOCKSTEP_QOS)
    wait_for_recorder(node, ['drive/measurement'], timeout=20.0)
    before = time.time_ns()
    for k in range(100):
        pub.publish(measurement_factory(k))

    def flushed() -> int:
        with open(bag / 'bag_0.mcap', 'rb') as stream:
            return sum(1 for _ in intact_messages(stream, [], 'bag_0.mcap'))
    wait_until(lambda: flushed() == 100, timeout=30.0)   # the recorder flushes on its own, no stop needed
    after = time.time_ns()
    assert _stop(recorder, signal.SIGKILL) == -signal.SIGKILL
    assert not (bag / 'metadata.yaml').exists()
    assert reindex(bag).message_count == 100
    reader = BagReader(bag)
    assert reader.log_time_source == 'wall'
    messages = list(reader.messages())
    assert [reader.decode(m).step for m in messages] == list(range(100))
    assert all(before <= m.publish_time <= m.log_time <= after for m in messages)


def test_unknown_log_time_and_restart_on_a_killed_bag_are_refused(start_node, tmp_path, measurement_factory):
    bag = tmp_path / 'bag'
    recorder = _start_recorder(start_node, bag, log_time='gps')
    assert recorder.process.wait(timeout=20) == 2
    assert "log_time: 'gps'" in recorder.output() and not bag.exists()
    bag.mkdir()
    (bag / 'bag_0.mcap').write_bytes(b'\x89MCAP0\r\n')   # what a recorder killed at once leaves
    recorder = _start_recorder(start_node, bag)
    assert recorder.process.wait(timeout=20) == 2
    assert 'never finalized' in recorder.output() and f'ros2 run drive_logger reindex {bag}' in recorder.output()


def test_existing_output_directory_is_refused(start_node, tmp_path):
    bag = tmp_path / 'bag'
    bag.mkdir()
    (bag / 'keep.txt').write_text('mine')
    recorder = _start_recorder(start_node, bag)
    assert recorder.process.wait(timeout=20) == 2
    assert 'already exists' in recorder.output()
    assert sorted(p.name for p in bag.iterdir()) == ['keep.txt']


def test_unknown_topic_type_is_refused_before_writing(start_node, tmp_path):
    bag = tmp_path / 'bag'
    recorder = _start_recorder(start_node, bag, topics=['drive/measurement', 'foo:nonexistent_pkg/msg/Nope'])
    assert recorder.process.wait(timeout=20) == 2
    assert 'nonexistent_pkg/msg/Nope' in recorder.output()
    recorder = _start_recorder(start_node, bag, topics=['/not_in_graph'], type_discovery_timeout=0.3)
    assert recorder.process.wait(timeout=20) == 2
    assert 'unknown type' in recorder.output() and '/not_in_graph' in recorder.output()
    assert not bag.exists()


def test_out_of_range_batch_period_is_refused_before_writing(start_node, tmp_path):
    bag = tmp_path / 'bag'
    recorder = _start_recorder(start_node, bag, batch_period=0.5)
    assert recorder.process.wait(timeout=20) == 2
    assert 'batch_period out of range' in recorder.output()
    assert not bag.exists()


def test_wrongly_typed_parameter_is_refused_before_writing(start_node, tmp_path):
    bag = tmp_path / 'bag'
    recorder = _start_recorder(start_node, bag, drain_timeout='soon')
    assert recorder.process.wait(timeout=20) == 2
    assert 'drain_timeout' in recorder.output() and 'Traceback' not in recorder.output()
    assert not bag.exists()


def test_default_recording_takes_the_blocks_and_stays_off_the_lockstep_topics(
        ros_session, start_node, tmp_path, measurement_factory):
    """Default topics: blocks, /diagnostics, /clock, parameter events; no subscriber on a
    per-sample lockstep or live topic; every block published is in the bag, bit-exact."""
    from rclpy.serialization import deserialize_message

    from drive_common import topics
    from drive_common.telemetry_blocks import BlockPacker
    from drive_logger.graph_topics import DEFAULT_TOPICS, LOCKSTEP_TOPICS
    from drive_testing.block_probe import message_bits
    from dtc_msgs.msg import PlantState, PlantStateBlock
    assert topics.PLANT_STATE_BLOCK in DEFAULT_TOPICS
    assert not set(DEFAULT_TOPICS) & set(LOCKSTEP_TOPICS + [topics.PLANT_STATE, topics.DTC_STATUS])
    bag = tmp_path / 'bag'
    recorder = start_node('drive_logger', 'recorder', parameters={'output': str(bag)})
    node = ros_session.node('publisher')
    block_pub = node.create_publisher(PlantStateBlock, topics.PLANT_STATE_BLOCK, topics.BLOCK_QOS)
    meas_pub = node.create_publisher(DriveMeasurement, DRIVE_MEASUREMENT, LOCKSTEP_QOS)
    wait_for_recorder(node, DEFAULT_TOPICS, timeout=20.0)
    assert meas_pub.get_subscription_count() == 0 and node.count_subscribers(topics.PLANT_STATE) == 0
    packer, published = BlockPacker(PlantStateBlock, 40), []
    for k in range(400):
        state = PlantState(step=k, mechanical_speed=0.1 * k)
        block = packer.append(25_000 * k, state)
        if block is not None:
            published.append(message_bits(block))
            block_pub.publish(block)
        meas_pub.publish(measurement_factory(k))
    assert _stop(recorder) == 0, recorder.output()
    from drive_logger.bag_reader import BagReader
    reader = BagReader(bag)
    # the default topics, plus the viewer topic the recorder derives from the blocks (not subscribed)
    assert set(reader.topics) <= {'/' + t.lstrip('/') for t in DEFAULT_TOPICS} | {'/plant/state'}
    recorded = [message_bits(deserialize_message(m.data, PlantStateBlock))
                for m in reader.messages() if m.topic == '/plant/state_block']
    assert recorded == published and len(published) == 10
    # viewer topic: one sample per 1 ms of sim time (every 40th of 25 us), logged at its stamp
    viewer = [(m.log_time, deserialize_message(m.data, PlantState)) for m in reader.messages(['/plant/state'])]
    assert [s.step for _, s in viewer] == list(range(0, 400, 40))
    assert [t for t, _ in viewer] == [25_000 * s.step for _, s in viewer]
    assert [s.mechanical_speed for _, s in viewer] == [0.1 * s.step for _, s in viewer]


def test_recorders_matched_holds_until_the_recorder_has_matched_the_publisher(ros_session, start_node,
                                                                             tmp_path):
    """drive_common.recorder_matching against a real recorder: no recorder, nothing to wait for;
    a recorder of the topic, until its own subscription has matched the publisher."""
    from drive_common.recorder_matching import RecordersMatched
    node = ros_session.node('publisher')
    matched = RecordersMatched(node, [DRIVE_MEASUREMENT, GATE_COMMAND])
    assert matched() and matched.waiting_for == []          # no recorder in the graph
    required = RecordersMatched(node, [DRIVE_MEASUREMENT], required=['recorder/matched_publishers'])
    assert not required()                                    # the runner's own recorder: not up yet
    _start_recorder(start_node, tmp_path / 'bag', topics=['drive/measurement'])
    wait_for_recorder(node, ['drive/measurement'], timeout=30.0)
    fresh = RecordersMatched(node, [DRIVE_MEASUREMENT, GATE_COMMAND])
    assert not fresh() and fresh.waiting_for == ['/recorder/matched_publishers']   # no publisher yet
    pub = node.create_publisher(DriveMeasurement, DRIVE_MEASUREMENT, LOCKSTEP_QOS)
    wait_until(lambda: pub.get_subscription_count() >= 1, 30.0, what='the recorder, from our side')
    wait_until(fresh, 30.0, what='the recorder matched the publisher from its side')
    wait_until(required, 30.0, what='the required recorder answered')
    for check in (matched, required, fresh):
        check.destroy()
