"""An outsider can never harm a running graph; a second graph refuses before it touches the first
(docs/architecture.md, "Time and lockstep": peer binding; drive_common.domain_guard).

A scenario run through ``run_scenario`` records the same samples whether or
not, during its run, a CLI-style publisher sends garbage on every lockstep
topic (at a few Hz and in bursts), a second fake controller and a second
plant are started under other node names; the intruders are reported on
``/diagnostics`` with their node names.
"""
from __future__ import annotations

import os
import random
import signal
from collections import Counter
import subprocess
import sys

import pytest

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from drive_common import topics
from drive_common.waiting import wait_until
from drive_testing.block_bags import recorded_samples
from dtc_msgs.msg import (DriveMeasurement, DutyCommand, GateCommand, PfcMeasurement,
                          PlantStateBlock)

pytestmark = pytest.mark.ros

SCENARIO = 'pfc_load_and_line_steps'   # DTC and PFC: all four lockstep topics in use
DURATION = '0.05'                      # s of sim time: several s of wall time
INTRUDER_RATE = 5.0                    # Hz of the CLI-style intruder
BURST = 300                            # messages per topic in one burst


def run_scenario(*args) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, '-m', 'drive_bringup.runner_cli', SCENARIO,
                             '--duration', DURATION, *args],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def garbage(msg_type, rng: random.Random):
    """A valid message of a lockstep type with random content and a plausible step."""
    msg = msg_type()
    msg.step = rng.randrange(0, 5000)
    if msg_type is GateCommand:
        msg.topology = 6
        msg.switch_on = [rng.random() < 0.5 for _ in range(6)]
    elif msg_type is DutyCommand:
        msg.duty, msg.enable = rng.random(), True
    elif msg_type is DriveMeasurement:
        msg.phase_current = [rng.uniform(-50, 50) for _ in range(3)]
        msg.dc_link_voltage, msg.mechanical_speed = rng.uniform(0, 400), rng.uniform(-500, 500)
        msg.hall_code = rng.randrange(1, 7)
    else:
        msg.rectified_voltage, msg.output_voltage = rng.uniform(0, 40), rng.uniform(0, 100)
        msg.inductor_current = rng.uniform(0, 10)
    return msg


class CliIntruder:
    """What ``ros2 topic pub -r 5`` on every lockstep topic does, plus bursts."""

    TYPES = {topics.DRIVE_MEASUREMENT: DriveMeasurement, topics.GATE_COMMAND: GateCommand,
             topics.PFC_MEASUREMENT: PfcMeasurement, topics.DUTY_COMMAND: DutyCommand}

    def __init__(self, node) -> None:
        self.rng = random.Random(7)
        self.publishers = {t: (node.create_publisher(m, t, topics.LOCKSTEP_QOS), m)
                           for t, m in self.TYPES.items()}
        self.sent = 0
        node.create_timer(1.0 / INTRUDER_RATE, self.publish)

    def publish(self, count: int = 1) -> None:
        for publisher, msg_type in self.publishers.values():
            for _ in range(count):
                publisher.publish(garbage(msg_type, self.rng))
                self.sent += 1


@pytest.fixture(scope='module')
def alone_bag(tmp_path_factory):
    """The bag of the scenario run alone (a private domain)."""
    out = tmp_path_factory.mktemp('alone')
    run = run_scenario('--isolate', '--out', str(out))
    text, _ = run.communicate(timeout=600)
    assert run.returncode == 0, text
    return out / 'bag'


@pytest.fixture(scope='module')
def alone(alone_bag):
    """The samples of the scenario run alone."""
    return recorded_samples(alone_bag)


def viewer_messages(bag, namespace: str = '') -> dict[str, list]:
    """{per-sample viewer topic: [(log time, data)]} of a bag, for a drive under namespace."""
    from drive_logger.bag_reader import BagReader
    wanted = [namespace + t for t in ('/plant/state', '/dtc/status', '/pfc/status')]
    out = {t: [] for t in wanted}
    for msg in BagReader(bag).messages(wanted):
        out[msg.topic].append((msg.log_time, bytes(msg.data)))
    return {t[len(namespace):]: v for t, v in out.items()}


def assert_same_samples(alone: dict, bag) -> None:
    samples = recorded_samples(bag)
    assert set(samples) == set(alone), sorted(samples)
    assert {'/plant/state', '/dtc/status', '/pfc/status'} <= set(alone), sorted(alone)
    for topic in alone:
        assert samples[topic] == alone[topic], f'{topic}: not the samples of the run alone'


def test_intruders_on_every_lockstep_topic_change_nothing(alone, ros_session, ros_domain,
                                                          start_node, tmp_path):

    diagnostics: list[DiagnosticStatus] = []
    watcher = ros_session.node('diagnostics_watch')
    watcher.create_subscription(DiagnosticArray, topics.DIAGNOSTICS,
                                lambda m: diagnostics.extend(m.status), 100)
    blocks = []
    watcher.create_subscription(PlantStateBlock, topics.PLANT_STATE_BLOCK, blocks.append,
                                topics.BLOCK_QOS)
    run = run_scenario('--domain-id', str(ros_domain), '--out', str(tmp_path / 'intruded'))
    try:
        # The lockstep is under way (every peer bound): the intruders come in.
        wait_until(lambda: blocks or run.poll() is not None, 120.0, what='the run to start')
        intruder = CliIntruder(ros_session.node('intruder_cli'))
        intruder.publish(BURST)
        start_node('drive_testing', 'fixed_responder', node_name='second_controller')
        start_node('bldc_plant_sim', 'plant', node_name='second_plant')
        wait_until(lambda: any(s.level == DiagnosticStatus.WARN and 'intruder_cli' in s.message
                               for s in diagnostics) or run.poll() is not None, 60.0,
                   what='the intruder report')
        intruder.publish(BURST)
        out, _ = run.communicate(timeout=600)
    finally:
        if run.poll() is None:
            run.kill()
    assert run.returncode == 0, out
    assert intruder.sent >= 2 * 4 * BURST
    reported = {kv.value for s in diagnostics if s.level == DiagnosticStatus.WARN
                for kv in s.values if kv.key == 'intruder'}
    assert '/intruder_cli' in reported, [s.message for s in diagnostics]
    plant_reports = Counter((values['intruder'], values['topic']) for values in (
        {kv.key: kv.value for kv in s.values} for s in diagnostics if s.name.startswith('plant'))
        if 'intruder' in values)
    assert plant_reports[('/intruder_cli', '/drive/gate_command')] == 1, plant_reports   # once
    assert_same_samples(alone, tmp_path / 'intruded' / 'bag')


def test_a_second_run_in_the_domain_refuses_before_it_touches_the_first(alone, ros_domain,
                                                                        tmp_path):
    first = run_scenario('--domain-id', str(ros_domain), '--out', str(tmp_path / 'first'))
    try:
        for line in first.stdout:            # the first run's graph is up: a second run comes
            if 'graph up' in line:
                break
        # The first runner is paused while the second one looks: its graph stays up however
        # fast its short run ends (the plant finishes the goal; the runner collects it later).
        os.kill(first.pid, signal.SIGSTOP)
        try:
            second = subprocess.run([sys.executable, '-m', 'drive_bringup.runner_cli', SCENARIO,
                                     '--duration', DURATION, '--domain-id', str(ros_domain),
                                     '--out', str(tmp_path / 'second')],
                                    capture_output=True, text=True, timeout=120)
        finally:
            os.kill(first.pid, signal.SIGCONT)
        out, _ = first.communicate(timeout=600)
    finally:
        if first.poll() is None:
            first.kill()
    assert second.returncode == 2, second.stdout + second.stderr
    error = second.stderr.strip()
    assert len(error.splitlines()) == 1 and f'ROS domain {ros_domain}' in error, error
    # names the first graph's nodes it found (discovery may not have shown every one yet)
    assert 'refusing' in error and any(n in error for n in ('/plant', '/dtc_controller',
                                                            '/recorder', '/scenario_runner')), error
    assert not (tmp_path / 'second' / 'logs').exists(), 'the second run started a node'
    assert first.returncode == 0, out
    assert_same_samples(alone, tmp_path / 'first' / 'bag')



def test_two_namespaced_drives_in_one_domain_each_record_their_run_alone(alone, alone_bag, ros_domain,
                                                                          tmp_path):
    """Each drive has its own clock, diagnostics and parameter events under its namespace,
    and its bag holds only its own topics, with the samples of the run alone, and the
    per-sample viewer topics of the run alone under its namespace (what Foxglove plots)."""
    runs = {ns: run_scenario('--domain-id', str(ros_domain), '--namespace', ns,
                             '--out', str(tmp_path / ns)) for ns in ('drive1', 'drive2')}
    try:
        outputs = {ns: run.communicate(timeout=600)[0] for ns, run in runs.items()}
    finally:
        for run in runs.values():
            if run.poll() is None:
                run.kill()
    from drive_logger.bag_reader import BagReader
    for ns, run in runs.items():
        assert run.returncode == 0, outputs[ns]
        recorded = BagReader(tmp_path / ns / 'bag').recorded_topics
        assert all(t.startswith(f'/{ns}/') for t in recorded), sorted(recorded)
        assert recorded[f'/{ns}/clock'].message_count > 0
        assert_same_samples(alone, tmp_path / ns / 'bag')
        viewer = viewer_messages(tmp_path / ns / 'bag', f'/{ns}')
        assert all(viewer.values()) and viewer == viewer_messages(alone_bag), \
            {t: len(v) for t, v in viewer.items()}
        info = subprocess.run(['ros2', 'bag', 'info', str(tmp_path / ns / 'bag')],
                              capture_output=True, text=True, timeout=60)
        block_lines = [line for line in info.stdout.splitlines() if '_block |' in line]
        assert len(block_lines) == 3 and all(f'/{ns}/' in line and '| Samples: ' in line
                                             for line in block_lines), info.stdout + info.stderr
        state_line = next(line for line in info.stdout.splitlines() if f'/{ns}/plant/state |' in line)
        assert '| Samples: ' in state_line and state_line.endswith(f' in /{ns}/plant/state_block'), state_line
    # The analysis reads a namespaced drive as the same drive without a namespace.
    from drive_analysis.bag_columns import load_columns
    assert load_columns(str(tmp_path / 'drive1' / 'bag'))['/plant/state']['step'].size == \
        len(alone['/plant/state'])


def test_an_intruder_that_sent_and_left_is_still_reported(ros_session, ros_domain):
    """Messages taken after their publisher left the graph (a loaded receiver) are reported:
    named by the intruder node's other endpoints, or by gid when the run ends (flush)."""
    from drive_common.peer_binding import PeerBinding
    from drive_testing.harness import RosSession
    reports = []
    listener = ros_session.node('binding_listener')
    binding = PeerBinding(listener, '/bound/command', '/bound/measurement',
                          report=lambda message, values: reports.append(values))
    outsider = RosSession(ros_domain)       # its own DDS participant, as another process
    try:
        node = outsider.node('hit_and_run')
        pub = node.create_publisher(GateCommand, '/bound/command', topics.LOCKSTEP_QOS)

        def gids():
            return [bytes(i.endpoint_gid) for i in listener.get_publishers_info_by_topic('/bound/command')
                    if i.node_name == 'hit_and_run']
        wait_until(lambda: gids(), 30.0, what="the outsider's publisher in the graph")
        gid = gids()[0]
        node.destroy_publisher(pub)
        wait_until(lambda: not listener.get_publishers_info_by_topic('/bound/command'), 30.0,
                   what='the publisher gone from the graph')
        assert binding.accepts(gid) is False
        assert [r['intruder'] for r in reports] == ['/hit_and_run'], reports
        assert binding.accepts(gid) is False and len(reports) == 1, 'reported once'
    finally:
        outsider.close()
    stranger = bytes(range(1, 17))          # a participant the graph never knew
    assert binding.accepts(stranger) is False
    binding.check()
    assert len(reports) == 1, 'nothing to name it by yet: kept, not reported by a guess'
    binding.flush()
    assert reports[-1]['intruder'] == f'an undiscovered node (publisher gid {stranger.hex()})', reports
    assert reports[-1]['intruder_gid'] == stranger.hex()
    binding.flush()
    assert len(reports) == 2, 'reported once'
