"""Sim-time bags through the ROS graph.

- The same scenario recorded twice gives the same (topic, log time, data) for
  every sim-stamped message, and the same (log time, content) for the
  scenario's parameter changes on /parameter_events (stamped with sim time by
  the drive nodes, logged at their stamp); metadata.yaml and the MCAP summary agree with the
  sim times; rosbags and the mcap ROS 2 reader open the bag.
- A recorder killed with SIGKILL mid-run leaves a bag that reindex completes:
  standard readers open it, and each topic holds a prefix of what the complete
  recording of the same run holds (nothing invented, nothing reordered), as
  much as the last flushed chunk carried.
"""
import os
import signal
import threading
from pathlib import Path

import pytest
import yaml

from drive_bringup.runner import GraphRunner, RunFailed
from drive_bringup.scenario import find_scenario, load_scenario
from drive_common.waiting import wait_until
from drive_testing.harness import reserve_domain
from drive_logger.bag_reader import intact_messages
from drive_logger.message_definitions import is_sim_stamp

pytestmark = pytest.mark.ros

SCENARIO = 'two_phase_six_switch_torque_step'
DURATION = 0.1              # s of sim time: 3000 samples at 30 kHz, the torque step at 9.4 ms included
EVENTS = '/parameter_events'   # stamped by their node: sim time (drive nodes) or wall clock
SCENARIO_EVENTS = load_scenario(find_scenario(SCENARIO)).events
KILL_AFTER = 300            # measurements in flushed chunks before the recorder is killed


def _run(out: Path, duration: float, watcher=None):
    scenario = load_scenario(find_scenario(SCENARIO))
    scenario.duration = duration
    scenario.record_lockstep = True     # the raw lockstep topics too (on request): one message a sample
    with reserve_domain() as domain:
        runner = GraphRunner(scenario, out, domain_id=domain, progress=lambda _line: None)
        if watcher is not None:
            threading.Thread(target=watcher, args=(runner,), daemon=True).start()
        return runner.run()


def _by_topic(bag: Path) -> dict[str, list[tuple[int, bytes]]]:
    """topic -> [(log_time, data)] in file order, from the intact records of the bag's data file."""
    out: dict[str, list[tuple[int, bytes]]] = {}
    (data_file,) = bag.glob('*.mcap')
    with open(data_file, 'rb') as stream:
        problems = []
        for _, channel, message in intact_messages(stream, problems, str(data_file)):
            out.setdefault(channel.topic, []).append((message.log_time, bytes(message.data)))
    return out


def _scenario_change(data: bytes) -> bool:
    """A parameter event of one of the scenario's changes (made once the graph is up).

    Events of the nodes' start-up (rclpy's use_sim_time, the schema's declarations,
    the plant's motor-file values) are recorded or not depending on whether the
    recorder had matched the node yet, so they are left out of the comparison.
    """
    from rcl_interfaces.msg import ParameterEvent
    from rclpy.serialization import deserialize_message
    event = deserialize_message(data, ParameterEvent)
    changed = {p.name for p in event.changed_parameters}
    return any(event.node == '/' + e.node and changed and changed <= set(e.parameters) for e in SCENARIO_EVENTS)


def _deterministic(by_topic: dict) -> dict:
    """by_topic with only the scenario's parameter changes among the parameter events.

    The recorder writes every message in canonical CDR (zeroed padding), so
    the events are compared byte for byte like every other topic.
    """
    out = dict(by_topic)
    if EVENTS in out:
        out[EVENTS] = [(t, d) for t, d in out[EVENTS] if _scenario_change(d)]
    return out


@pytest.fixture(scope='module')
def reference_bags(tmp_path_factory):
    root = tmp_path_factory.mktemp('sim_time_bags')
    return [_run(root / f'run{i}', DURATION).bag for i in (1, 2)]


def test_same_scenario_twice_gives_identical_data_and_log_times(reference_bags):
    first, second = (_deterministic(_by_topic(b)) for b in reference_bags)
    samples = round(DURATION * 30000)
    assert len(first['/drive/measurement']) == samples
    for topic in set(first) | set(second):
        assert first.get(topic) == second.get(topic), f'{topic} differs between two recordings'
    # the scenario's torque step at the hold at 9.4 ms: the controller's event is stamped with
    # the last sample it answered before the hold, and logged there
    from rcl_interfaces.msg import ParameterEvent
    from rclpy.serialization import deserialize_message
    events = [(t, deserialize_message(d, ParameterEvent)) for t, d in first[EVENTS]]
    changes = [(t, e) for t, e in events if e.node == '/dtc_controller' and e.changed_parameters]
    assert [p.name for _, e in changes for p in e.changed_parameters] == ['torque_reference']
    (log_time, event), = changes
    assert is_sim_stamp(log_time) and log_time == event.stamp.sec * 1_000_000_000 + event.stamp.nanosec
    hold_step = round(0.0094 * 30000)
    assert log_time == first['/drive/measurement'][hold_step - 1][0]    # the sample before the hold
    # wall-stamped events (start-up declarations) land inside the bag's sim-time range
    assert all(0 <= t <= DURATION * 1e9 for t, _ in _by_topic(reference_bags[0]).get(EVENTS, []))
    # log time = the sample's sim time: measurement k at k * 1/30 kHz (ns, rounded as the plant stamps it)
    times = [t for t, _ in first['/drive/measurement']]
    assert times[0] == 0 and times == sorted(times) and abs(times[-1] - (samples - 1) * 1e9 / 30000) < 1000


def test_sim_time_bag_metadata_summary_and_standard_readers_agree(reference_bags):
    bag = reference_bags[0]
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    with open(bag / 'bag_0.mcap', 'rb') as f:
        stats = make_reader(f).get_summary().statistics
    assert meta['custom_data'] == {'log_time': 'sim'}
    assert meta['starting_time']['nanoseconds_since_epoch'] == stats.message_start_time == 0
    assert meta['duration']['nanoseconds'] == stats.message_end_time - stats.message_start_time
    assert stats.message_end_time <= DURATION * 1e9 + 1000          # a 0.1 s run spans 0.1 s
    assert meta['message_count'] == stats.message_count
    counts = {e['topic_metadata']['name']: e['message_count'] for e in meta['topics_with_message_count']}
    by_topic = _by_topic(bag)
    assert counts == {t: len(v) for t, v in by_topic.items()} | {t: 0 for t in counts if t not in by_topic}
    from rosbags.rosbag2 import Reader
    with Reader(bag) as reader:
        assert reader.message_count == meta['message_count']
        assert reader.start_time == 0 and reader.duration == meta['duration']['nanoseconds'] + 1
        assert sum(1 for _ in reader.messages()) == meta['message_count']
    with open(bag / 'bag_0.mcap', 'rb') as f:
        steps = [d.step for _, c, _, d in make_reader(f, decoder_factories=[DecoderFactory()])
                 .iter_decoded_messages(topics=['/drive/measurement'])]
    assert steps == list(range(round(DURATION * 30000)))


def test_sigkilled_recorder_bag_is_reindexed_to_what_it_had_flushed(reference_bags, tmp_path):
    from drive_logger.bag_reindex import main
    out = tmp_path / 'killed'
    bag = out / 'bag'
    killed = threading.Event()

    def kill_recorder_mid_run(runner):
        def flushed_recorder():
            """The recorder, once KILL_AFTER measurements are in its flushed chunks."""
            recorder = runner.processes.get('recorder')
            if recorder is not None and bag.is_dir() and any(bag.glob('*.mcap')):
                if len(_by_topic(bag).get('/drive/measurement', [])) >= KILL_AFTER:
                    return recorder
            return None

        recorder = wait_until(flushed_recorder, 300.0, 0.05, raise_timeout=False)
        if recorder is not None:             # else timed out: the test fails on `killed` below
            os.killpg(recorder.pid, signal.SIGKILL)
            killed.set()

    with pytest.raises(RunFailed, match='node recorder was killed by SIGKILL'):
        _run(out, 1.0, kill_recorder_mid_run)       # 10 x the reference: still running at the kill
    assert killed.is_set()
    assert not (bag / 'metadata.yaml').exists()
    intact = _by_topic(bag)

    assert main([str(bag)]) == 0
    reindexed = _by_topic(bag)
    assert reindexed == intact                      # every flushed message is there, in file order
    reference = _deterministic(_by_topic(reference_bags[0]))
    measured = len(reindexed['/drive/measurement'])
    assert KILL_AFTER <= measured < round(1.0 * 30000)      # part of the killed 1 s run
    # Nothing invented, nothing reordered: the same messages as the reference run, as far as
    # both go (under load the kill may land past the reference's 0.1 s).
    for topic, messages in _deterministic(reindexed).items():
        common = min(len(messages), len(reference[topic]))
        assert messages[:common] == reference[topic][:common], topic

    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    counts = {e['topic_metadata']['name']: e['message_count'] for e in meta['topics_with_message_count']}
    assert {t: n for t, n in counts.items() if n} == {t: len(v) for t, v in reindexed.items()}
    assert meta['message_count'] == sum(counts.values())
    from rosbags.rosbag2 import Reader
    with Reader(bag) as reader:
        got = {}
        for connection, timestamp, raw in reader.messages():
            got.setdefault(connection.topic, []).append((timestamp, bytes(raw)))
    assert {t: sorted(v) for t, v in got.items()} == {t: sorted(v) for t, v in reindexed.items()}
    # the mcap ROS 2 reader (make_reader + mcap_ros2's DecoderFactory; its old reader module is deprecated)
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    with open(bag / 'bag_0.mcap', 'rb') as f:
        decoded = [(m.log_time, d.step) for _, _, m, d in make_reader(f, decoder_factories=[DecoderFactory()])
                   .iter_decoded_messages(topics=['/drive/measurement'])]
    assert [step for _, step in decoded] == list(range(measured))
    assert [t for t, _ in decoded] == [t for t, _ in reindexed['/drive/measurement']]
