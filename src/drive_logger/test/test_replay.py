"""Replay node and the compare_replay regression, against a deterministic responder process."""
import subprocess
import sys
import threading
import time

import pytest
from rclpy.duration import Duration
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message

from drive_testing.harness import NodeProcess, executable_path, isolated_env
from drive_common.cdr_padding import canonicalize
from drive_common.waiting import wait_until
from drive_common.topics import DRIVE_MEASUREMENT, GATE_COMMAND, LOCKSTEP_QOS
from drive_logger import qos_yaml
from drive_logger.bag_writer import BagWriter
from drive_logger.compare_replay import replay_and_compare
from drive_logger.message_definitions import type_definition
from drive_logger.readiness import wait_for_recorder
from dtc_msgs.msg import DriveMeasurement, GateCommand

pytestmark = pytest.mark.ros
STEPS = 300


def test_replay_publishes_exact_bytes_with_clock_and_remap(ros_session, start_node, tmp_path, measurement_factory):
    writer = BagWriter(tmp_path / 'bag')
    topic = writer.add_topic('/drive/measurement', type_definition('dtc_msgs/msg/DriveMeasurement'),
                             [qos_yaml.profile()])
    sent = []
    for k in range(200):
        data = serialize_message(measurement_factory(k))
        sent.append(data)
        writer.write(topic, data, 1_000_000_000 + k * 1_000_000, 1_000_000_000 + k * 1_000_000)  # 1 ms apart
    writer.close()
    node = ros_session.node('listener')
    got, clocks = [], []
    from rosgraph_msgs.msg import Clock
    deep = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)  # a timed replay does not wait for slow takers
    node.create_subscription(DriveMeasurement, '/replayed', lambda d: got.append(d), deep, raw=True)
    node.create_subscription(Clock, '/clock', lambda m: clocks.append(m.clock.sec * 10**9 + m.clock.nanosec), 100)
    start = time.monotonic()
    start_node('drive_logger', 'replay', parameters={
        'bag': str(tmp_path / 'bag'), 'rate': 2.0, 'remap': ['/drive/measurement:=/replayed'],
        'wait_for_subscribers': 10.0})
    try:
        wait_until(lambda: len(got) >= 200, 15.0, what='200 replayed messages')
    finally:
        print('received', len(got), 'clocks', len(clocks))
    assert time.monotonic() - start > 0.199 / 2.0   # paced: 199 ms of bag at rate 2
    # the recorded bytes, in order (rmw pads a payload to a multiple of 4 bytes)
    assert ([canonicalize(d, DriveMeasurement) for d in got]
            == [canonicalize(d, DriveMeasurement) for d in sent])
    assert clocks and clocks[-1] == 199 * 25_000 and clocks == sorted(clocks)


def test_damaged_bag_replay_is_a_clear_error(start_node, tmp_path):
    (tmp_path / 'bag').mkdir()
    (tmp_path / 'bag' / 'bag_0.mcap').write_bytes(b'\x89MCAP0\r\n' + b'\x00' * 100)
    replay = start_node('drive_logger', 'replay', parameters={'bag': str(tmp_path / 'bag')})
    assert replay.process.wait(timeout=20) == 2
    assert 'no metadata.yaml' in replay.output() and 'truncated' in replay.output()


def test_wrongly_typed_replay_parameter_is_a_clear_error(start_node, tmp_path):
    replay = start_node('drive_logger', 'replay', parameters={'bag': str(tmp_path), 'rate': 'fast'})
    assert replay.process.wait(timeout=20) == 2
    assert 'rate' in replay.output() and 'Traceback' not in replay.output()


def _record_lockstep_run(ros_session, start_node, bag, measurement_factory):
    """A stand-in plant drives the responder step by step while the recorder records."""
    recorder = start_node('drive_logger', 'recorder', parameters={
        'output': str(bag), 'topics': [DRIVE_MEASUREMENT, GATE_COMMAND]})
    responder = NodeProcess('drive_testing', 'replay_responder', env=isolated_env(ros_session.domain_id), log_dir=bag.parent / 'nodes')
    try:
        node = ros_session.node('plant_standin')
        replies = {}
        arrived = threading.Condition()

        def on_gate(msg):
            with arrived:
                replies[msg.step] = msg
                arrived.notify_all()

        node.create_subscription(GateCommand, GATE_COMMAND, on_gate, LOCKSTEP_QOS)
        pub = node.create_publisher(DriveMeasurement, DRIVE_MEASUREMENT, LOCKSTEP_QOS)
        wait_for_recorder(node, [DRIVE_MEASUREMENT, GATE_COMMAND], timeout=20.0)
        wait_until(lambda: pub.get_subscription_count() >= 2 and node.count_publishers(GATE_COMMAND) >= 1, 20.0,
                   what='responder matched')
        # the responder's publisher matched the recorder and us (out of our sight: it logs it)
        wait_until(lambda: 'gate_command matched 2 subscription(s)' in responder.output(), 20.0,
                   what='responder gate_command matched')
        for k in range(STEPS):
            pub.publish(measurement_factory(k))
            with arrived:
                assert arrived.wait_for(lambda: k in replies, timeout=30.0), f'no reply for step {k}'
        # everything reached the recorder: our measurements and the responder's replies acknowledged
        assert pub.wait_for_all_acked(Duration(seconds=30.0))
        wait_until(lambda: f'gate_command acknowledged through step {STEPS - 1}' in responder.output(), 30.0,
                   what='the replies acknowledged')
    finally:
        recorder.stop()    # first: the responder stays up to deliver what is still in flight
        responder.stop()
    return replies


def test_replay_into_fresh_controller_reproduces_gate_commands(ros_session, start_node, tmp_path,
                                                              measurement_factory):
    bag = tmp_path / 'run'
    _record_lockstep_run(ros_session, start_node, bag, measurement_factory)

    fresh = NodeProcess('drive_testing', 'replay_responder', env=isolated_env(ros_session.domain_id), log_dir=tmp_path / 'fresh')
    try:
        report = replay_and_compare(str(bag), fresh, context=ros_session.context)
    finally:
        fresh.stop()
    assert report.steps_replayed == STEPS and report.steps_compared == STEPS
    assert report.missing_replies == [] and report.mismatch_count == 0 and report.identical

    # the CLI, with a controller that loses the first measurement (re-sent, then answered) and
    # differs at one step: caught exactly there, exit code 1
    result = subprocess.run(
        [sys.executable, '-m', 'drive_logger.compare_replay', str(bag), '--command',
         str(executable_path('drive_testing', 'replay_responder')),
         '-p', 'corrupt_step:=123', '-p', 'drop_first:=true', '--json', str(tmp_path / 'report.json')],
        env=isolated_env(ros_session.domain_id), capture_output=True, text=True, timeout=120)
    assert result.returncode == 1, result.stdout + result.stderr
    import json
    report = json.loads((tmp_path / 'report.json').read_text())
    assert report['mismatch_count'] == 1 and report['first_mismatch_step'] == 123
    assert report['missing_replies'] == [] and report['steps_compared'] == STEPS
    assert report['mismatches'][0]['recorded']['switch_on'][0] != report['mismatches'][0]['replayed']['switch_on'][0]


def test_replay_of_one_namespaced_drive_into_a_namespace(ros_session, start_node, tmp_path,
                                                         measurement_factory):
    """A bag of two drives (/drive1, /drive2): namespace chooses one, its topics go out under the
    replay node's namespace; without a choice the replay refuses, naming both."""
    writer = BagWriter(tmp_path / 'bag')
    definition = type_definition('dtc_msgs/msg/DriveMeasurement')
    sent = {ns: [] for ns in ('/drive1', '/drive2')}
    topics = {ns: writer.add_topic(ns + '/drive/measurement', definition, [qos_yaml.profile()])
              for ns in sent}
    for k in range(50):
        for ns, topic in topics.items():
            data = serialize_message(measurement_factory(k if ns == '/drive1' else 1000 + k))
            sent[ns].append(data)
            writer.write(topic, data, 1_000_000_000 + k * 1_000_000, 1_000_000_000 + k * 1_000_000)
    writer.close()
    undecided = start_node('drive_logger', 'replay', parameters={'bag': str(tmp_path / 'bag')})
    assert undecided.process.wait(timeout=20) == 2
    assert '/drive1, /drive2' in undecided.output(), undecided.output()
    got = []
    deep = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
    ros_session.node('listener').create_subscription(
        DriveMeasurement, '/replayed_drive/drive/measurement', got.append, deep, raw=True)
    start_node('drive_logger', 'replay', remappings={'__ns': '/replayed_drive'}, parameters={
        'bag': str(tmp_path / 'bag'), 'namespace': '/drive2', 'rate': 0.0,
        'wait_for_subscribers': 10.0, 'publish_clock': False})
    wait_until(lambda: len(got) >= 50, 15.0, what='the replayed drive')
    assert ([canonicalize(d, DriveMeasurement) for d in got]
            == [canonicalize(d, DriveMeasurement) for d in sent['/drive2']])
