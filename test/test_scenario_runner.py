"""The launch-free scenario runner through real ROS processes.

- A scenario runs as separate processes, events land at exact sim times,
  the run is recorded and reported.
- The ROS graph and the headless loop give the same trajectory.
- Running a scenario twice gives the same bag file, byte for byte.
- A node that crashes is reported; Ctrl-C stops every process.
"""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from rcl_interfaces.msg import ParameterEvent
from rclpy.serialization import deserialize_message

from drive_bringup.headless import run_headless
from drive_bringup.scenario import find_scenario, load_scenario
from drive_common.starter import STARTER_PID_VARIABLE
from drive_testing.harness import isolated_env, processes_with_env
from drive_common.waiting import wait_until

pytestmark = pytest.mark.ros

SCENARIO = 'two_phase_six_switch_torque_step'
DURATION = 0.012   # s: covers the torque step at 9.4 ms


def run_cli(*args, timeout=300, **kwargs):
    return subprocess.run([sys.executable, '-m', 'drive_bringup.runner_cli', *args],
                          capture_output=True, text=True, timeout=timeout, **kwargs)


def bag_messages(bag_dir: Path) -> dict[str, list[bytes]]:
    out: dict[str, list[bytes]] = {}
    mcap = next(bag_dir.glob('*.mcap'))
    with open(mcap, 'rb') as f:
        for _, channel, message in make_reader(f).iter_messages(log_time_order=False):
            out.setdefault(channel.topic, []).append(message.data)
    return out


@pytest.fixture(scope='module')
def recorded_run(tmp_path_factory):
    out = tmp_path_factory.mktemp('run') / 'out'
    result = run_cli(SCENARIO, '--duration', str(DURATION), '--isolate', '--out', str(out))
    assert result.returncode == 0, result.stdout + result.stderr
    return out, result


def test_run_is_recorded_and_reported(recorded_run):
    out, result = recorded_run
    assert 't = 0.009400 s: dtc_controller torque_reference = 0.5157' in result.stdout
    meta = (out / 'bag' / 'metadata.yaml').read_text()
    assert 'version: 9' in meta and 'storage_identifier: mcap' in meta
    from rclpy.serialization import deserialize_message

    from dtc_msgs.msg import DtcStatusBlock, PlantStateBlock
    messages = bag_messages(out / 'bag')
    samples = round(DURATION * 30000)
    # Every sample in blocks; no per-sample lockstep topic recorded by default; the viewer
    # topics derived from the blocks at 1 ms of sim time.
    assert not {'/drive/measurement', '/drive/gate_command'} & set(messages)
    assert len(messages['/plant/state']) == 13 and len(messages['/dtc/status']) == 12   # t = 0, 1, ... ms

    def steps(topic, block_type):
        blocks = [deserialize_message(data, block_type) for data in messages[topic]]
        return [b.first_step + i * b.step_stride for b in blocks for i in range(b.count)]
    assert steps('/dtc/status_block', DtcStatusBlock) == list(range(samples))
    assert steps('/plant/state_block', PlantStateBlock) == list(range(samples + 1))   # t_0 .. t_N
    report = json.loads((out / 'report.json').read_text())
    assert report['scenario'] == SCENARIO
    assert report['checks'] and all('pass' in row for row in report['checks'])
    assert (out / 'figures' / 'torque.png').stat().st_size > 10_000


def test_ros_graph_and_headless_loop_give_the_same_trajectory(recorded_run):
    from drive_analysis.bag_columns import load_columns
    out, _ = recorded_run
    ros = load_columns(str(out / 'bag'))['/plant/state']
    scenario = load_scenario(find_scenario(SCENARIO)).shortened(DURATION)
    headless = run_headless(scenario).arrays()
    assert np.array_equal(ros['step'], headless['plant/state.step'])
    for name in ('phase_current', 'electromagnetic_torque', 'mechanical_speed', 'rotor_angle',
                 'energy_copper_loss'):
        assert np.array_equal(ros[name], headless[f'plant/state.{name}']), name


def test_headless_run_prints_and_writes_the_report_a_graph_run_does(recorded_run, tmp_path):
    graph_out, graph = recorded_run
    out = tmp_path / 'headless'
    result = run_cli(SCENARIO, '--headless', '--duration', str(DURATION), '--out', str(out))
    assert result.returncode == 0, result.stdout + result.stderr
    graph_report = json.loads((graph_out / 'report.json').read_text())
    report = json.loads((out / 'report.json').read_text())
    assert report['bag'] is None and (out / 'trajectory.npz').stat().st_size > 0
    assert report['sim_time'] == pytest.approx(graph_report['sim_time'])
    assert sorted(report['figures']) == sorted(graph_report['figures'])
    assert (out / 'figures' / 'torque.png').stat().st_size > 10_000
    assert report['metrics'] == graph_report['metrics']    # the same trajectory, bit for bit
    assert ([(r['label'], r['pass']) for r in report['checks']]
            == [(r['label'], r['pass']) for r in graph_report['checks']])
    for printed in (graph.stdout, result.stdout):   # the same summary lines (print_summary)
        assert 'report  ' in printed and 'figures ' in printed
        for row in report['checks']:
            assert f'] {row["label"]}: ' in printed, row['label']
    assert f'none (headless: {out / "trajectory.npz"})' in result.stdout


def test_a_program_that_is_not_built_is_refused_before_the_output_directory(tmp_path):
    scenario = tmp_path / 'unbuilt.yaml'
    shipped = find_scenario('example_hysteresis_current_control').read_text()
    for old, new, expected in (('package: drive_examples', 'package: no_such_pkg', "no package 'no_such_pkg'"),
                               ('executable: hysteresis_current_controller', 'executable: no_such_exe',
                                "no executable 'no_such_exe'")):
        assert old in shipped
        scenario.write_text(shipped.replace(old, new))
        out = tmp_path / 'out'
        result = run_cli(str(scenario), '--isolate', '--out', str(out), timeout=120)
        lines = [line for line in (result.stdout + result.stderr).splitlines() if line.strip()]
        assert result.returncode == 2, lines
        assert len(lines) == 1 and 'nodes.controller' in lines[0] and expected in lines[0], lines
        assert not out.exists()


def test_duration_lengthens_a_live_run_and_only_shortens_others(tmp_path):
    from drive_bringup.runner_cli import build_parser, prepare_run
    from drive_bringup.scenario import ScenarioError
    out = tmp_path / 'o'
    live = build_parser().parse_args([SCENARIO, '--live', '--duration', '3.0', '--out', str(out)])
    scenario, _ = prepare_run(live)
    assert scenario.duration == 3.0 and load_scenario(find_scenario(SCENARIO)).duration < 3.0
    assert [e.time for e in scenario.events] == [e.time for e in load_scenario(find_scenario(SCENARIO)).events]
    graph = build_parser().parse_args([SCENARIO, '--duration', '3.0', '--out', str(out)])
    with pytest.raises(ScenarioError, match='outside'):
        prepare_run(graph)
    assert not out.exists()


def test_same_scenario_twice_gives_identical_bag_files(recorded_run, tmp_path):
    first, _ = recorded_run
    again = tmp_path / 'again'
    result = run_cli(SCENARIO, '--duration', str(DURATION), '--isolate', '--out', str(again))
    assert result.returncode == 0, result.stderr
    a, b = bag_messages(first / 'bag'), bag_messages(again / 'bag')
    for topic in ('/dtc/status_block', '/plant/state_block', '/clock', '/plant/state', '/dtc/status',
                  '/parameter_events'):
        assert a[topic] == b[topic], f'{topic} differs between two runs'
    # no start-up parameter event is recorded (whether it came after discovery varies)
    events = [deserialize_message(data, ParameterEvent) for data in a['/parameter_events']]
    assert events and all(e.changed_parameters or e.deleted_parameters for e in events)
    assert (first / 'bag' / 'bag_0.mcap').read_bytes() == (again / 'bag' / 'bag_0.mcap').read_bytes()
    assert (first / 'bag' / 'metadata.yaml').read_text() == (again / 'bag' / 'metadata.yaml').read_text()


def test_crashed_node_is_reported(tmp_path):
    scenario = tmp_path / 'broken.yaml'
    scenario.write_text(find_scenario(SCENARIO).read_text().replace(
        'package://bldc_plant_sim/motors/ozturk_bldc_nonideal_backemf.csv',
        str(tmp_path / 'missing_table.csv')).replace(f'name: {SCENARIO}', 'name: broken'))
    result = run_cli(str(scenario), '--isolate', '--no-record', '--out', str(tmp_path / 'o'))
    assert result.returncode == 1
    assert 'dtc_controller exited' in result.stderr and 'missing_table.csv' in result.stderr


def _flushed_messages(bag: Path, topic: str) -> int:
    """Messages of topic in the bag's data files so far (the intact part of a bag being written)."""
    from drive_logger.bag_reader import intact_messages
    count = 0
    for path in bag.glob('*.mcap'):
        with open(path, 'rb') as stream:
            count += sum(1 for _, channel, _ in intact_messages(stream, [], path.name) if channel.topic == topic)
    return count


def test_ctrl_c_stops_every_node(tmp_path):
    out = tmp_path / 'interrupted'
    marker = f'DTC_TEST_MARKER=ctrl_c_{os.getpid()}_{time.monotonic_ns()}'
    env = dict(os.environ, DTC_TEST_MARKER=marker.split('=', 1)[1])
    # A long scenario (3 s of sim time, minutes of wall time): still running at the SIGINT.
    process = subprocess.Popen([sys.executable, '-m', 'drive_bringup.runner_cli',
                                'two_phase_six_switch_flux_control',
                                '--isolate', '--out', str(out)], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, env=env)
    try:
        def graph_started() -> bool:
            assert process.poll() is None, 'the runner ended early'
            return (out / 'logs').exists() and len(list((out / 'logs').glob('*.log'))) >= 3

        wait_until(graph_started, 120.0, 0.2, 'the node processes')

        def run_under_way() -> bool:     # plant state blocks reached the bag (flushed every 0.5 s)
            assert process.poll() is None, 'the runner ended early'
            return _flushed_messages(out / 'bag', '/plant/state_block') >= 10

        wait_until(run_under_way, 120.0, 0.2, 'plant state blocks in the bag')
        process.send_signal(signal.SIGINT)
        _, stderr = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 130, stderr
    assert 'interrupted' in stderr
    assert processes_with_env(marker) == [], 'orphan node processes left behind'
    # The recorder was stopped cleanly: the bag is finalized and readable.
    assert (out / 'bag' / 'metadata.yaml').exists()


def test_replay_into_a_fresh_controller_reproduces_its_gate_commands(recorded_run, tmp_path,
                                                                      ros_domain):
    """A recorded run re-drives a new dtc_controller; the gates match step for step,
    across the scenario's runtime parameter change (taken from the recorded /parameter_events)."""
    import yaml
    out, _ = recorded_run
    scenario = load_scenario(find_scenario(SCENARIO))
    params = tmp_path / 'dtc.yaml'
    params.write_text(yaml.safe_dump({'dtc_controller': {'ros__parameters': scenario.overrides['dtc_controller']}}))
    report = tmp_path / 'compare.json'
    result = subprocess.run(
        [sys.executable, '-m', 'drive_logger.compare_replay', str(out / 'bag'),
         '--package', 'dtc_controller', '--executable', 'dtc_controller',
         '--params-file', str(params), '--json', str(report)],
        capture_output=True, text=True, timeout=300,
        env=isolated_env(ros_domain))
    assert result.returncode == 0, result.stdout + result.stderr
    summary = json.loads(report.read_text())
    samples = round(DURATION * 30000)
    assert summary['steps_compared'] == samples and summary['mismatch_count'] == 0, summary
    assert summary['parameter_changes'] == 1       # the torque step at 9.4 ms, re-applied in place


@pytest.mark.parametrize('name', ['two_phase_four_switch_torque_step', 'three_phase_dtifc_sensorless',
                                  'fstp_voltage_model_proposed_compensation', 'pfc_no_load_fig_3_5'])
def test_every_inverter_and_conduction_mode_runs_the_same_through_ros(name, tmp_path):
    """The closed-loop results shown headless hold for the ROS graph: same trajectory.

    One scenario per inverter/conduction family, and the PFC front end with its
    own controller at twice the DTC rate.
    """
    from drive_analysis.bag_columns import load_columns
    duration = 0.006
    out = tmp_path / name
    result = run_cli(name, '--duration', str(duration), '--isolate', '--out', str(out))
    assert result.returncode == 0, result.stdout + result.stderr
    columns = load_columns(str(out / 'bag'))
    scenario = load_scenario(find_scenario(name)).shortened(duration)
    headless = run_headless(scenario).arrays()
    state = columns['/plant/state']
    assert np.array_equal(state['step'], headless['plant/state.step'])
    for field in ('phase_current', 'electromagnetic_torque', 'rotor_angle'):
        assert np.array_equal(state[field], headless[f'plant/state.{field}']), field
    status = columns['/dtc/status']
    assert np.array_equal(status['torque_estimate'], headless['dtc/status.torque_estimate'])
    assert np.ptp(state['phase_current'][:, 1]) > 0.5     # the drive actually switched current
    if 'pfc_controller' in scenario.nodes:                # boost PFC loop at 80 kHz, DTC at 40 kHz
        for field in ('inductor_current', 'grid_current', 'dc_link_voltage'):
            assert np.array_equal(state[field], headless[f'plant/state.{field}']), field
        pfc = columns['/pfc/status']
        recorded = np.isin(pfc['step'], headless['pfc/status.step'])   # headless keeps every 2nd
        assert recorded.sum() == len(headless['pfc/status.step'])
        assert np.array_equal(pfc['duty'][recorded], headless['pfc/status.duty'])
        assert np.ptp(state['inductor_current']) > 0.5


def _node_domains(argv, domain: int) -> set[str]:
    """Run run_scenario with ROS_DOMAIN_ID=domain; the ROS_DOMAIN_IDs its node processes got."""
    marker = f'DTC_TEST_MARKER=domain_{os.getpid()}_{time.monotonic_ns()}'
    env = dict(isolated_env(domain), DTC_TEST_MARKER=marker.split('=', 1)[1])
    process = subprocess.Popen([sys.executable, '-m', 'drive_bringup.runner_cli', *argv],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    domains: set[str] = set()

    def nodes_seen():
        for pid in processes_with_env(marker):
            if pid == process.pid:
                continue
            try:
                before = Path(f'/proc/{pid}/cmdline').read_bytes()
                environ = Path(f'/proc/{pid}/environ').read_bytes().split(b'\0')
                after = Path(f'/proc/{pid}/cmdline').read_bytes()
            except OSError:
                continue
            if before != after or b'\0--ros-args\0' not in before + b'\0':
                continue    # not (yet) a node: a child of the runner before or during its exec
            domains.update(v.split(b'=', 1)[1].decode() for v in environ
                           if v.startswith(b'ROS_DOMAIN_ID='))
        return process.poll() is not None

    try:
        wait_until(nodes_seen, 300.0, 0.02, 'the end of the run')
        _, stderr = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 0, stderr
    return domains


def test_run_scenario_runs_in_a_private_domain_unless_asked_to_join(tmp_path, ros_domain):
    base = ['two_phase_six_switch_flux_control', '--duration', '0.05', '--no-record']
    private = _node_domains(base + ['--out', str(tmp_path / 'private')], ros_domain)
    assert private and str(ros_domain) not in private
    joined = _node_domains(base + ['--out', str(tmp_path / 'joined'), '--join-domain'], ros_domain)
    assert joined == {str(ros_domain)}, joined
    given = _node_domains(base + ['--out', str(tmp_path / 'given'), '--domain-id', str(ros_domain)],
                          ros_domain % 100 + 101)     # the caller's own domain: another one
    assert given == {str(ros_domain)}, given


def _runner_line(out: Path) -> str:
    """A shell command running a long scenario (minutes of wall time) into out."""
    return (f'"{sys.executable}" -m drive_bringup.runner_cli two_phase_six_switch_flux_control '
            f'--isolate --out "{out}"')


def _shell_run(script: str, marker: str, graph_up) -> tuple[str, int]:
    """Run script in bash with DTC_TEST_MARKER=marker; call graph_up(said, shell) once the
    runner says 'graph up'. (Everything said, read to EOF: the runner is gone; bash's pid.)"""
    shell = subprocess.Popen(['bash', '-c', script], stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, text=True,
                             env=dict(os.environ, DTC_TEST_MARKER=marker))
    said = ''
    try:
        for line in shell.stdout:
            said += line
            if 'graph up' in line:         # the run is under way
                graph_up(said, shell)
        shell.wait(timeout=120)
    finally:
        shell.kill()
    return said, shell.pid


@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_background_run_of_a_script_stops_on_a_signal(tmp_path, sig):
    """A non-interactive shell starts a background job with SIGINT ignored: the runner still
    stops on SIGINT (and SIGTERM), with every node gone and the bag finalized."""
    out = tmp_path / 'background'
    marker = f'background_{os.getpid()}_{time.monotonic_ns()}'
    text, _ = _shell_run(f'{_runner_line(out)} & echo "pid $!"; wait $!; echo "exit $?"', marker,
                         lambda said, shell: os.kill(int(said.split('pid ')[1].split()[0]), sig))
    assert 'exit 130' in text and 'interrupted: all nodes stopped' in text, text
    assert processes_with_env(f'DTC_TEST_MARKER={marker}') == [], 'orphan node processes left behind'
    assert (out / 'bag' / 'metadata.yaml').exists()


def test_a_runner_whose_starter_is_killed_stops_every_node(tmp_path):
    """Runner and nodes have their own sessions: a starter killed with SIGKILL takes nothing
    down by signal. A runner that names it (drive_common.starter) stops as on Ctrl-C."""
    out = tmp_path / 'orphaned'
    marker = f'starter_{os.getpid()}_{time.monotonic_ns()}'
    text, starter = _shell_run(f'export {STARTER_PID_VARIABLE}=$$; {_runner_line(out)} & wait',
                               marker, lambda said, shell: shell.kill())
    assert f'(pid {starter}) has ended: stopping' in text, text
    assert 'interrupted: all nodes stopped' in text, text
    assert processes_with_env(f'DTC_TEST_MARKER={marker}') == [], 'orphan processes left behind'
    assert (out / 'bag' / 'metadata.yaml').exists()


def _tripping_scenario(tmp_path, expect: str = '') -> Path:
    """The torque-step scenario with a 1 A peak-current trip level: it trips within the run."""
    text = find_scenario(SCENARIO).read_text().replace(
        '      load.torque: 0.2292\n', '      load.torque: 0.2292\n      protection.peak_current: 1.0\n')
    text = text.replace(f'name: {SCENARIO}', 'name: tripping').replace(
        'duration: 0.04\n', 'duration: 0.04\n' + expect)
    path = tmp_path / 'tripping.yaml'
    path.write_text(text)
    return path


def test_a_run_that_ends_in_a_fault_state_exits_3_with_the_reason(tmp_path):
    scenario = _tripping_scenario(tmp_path)
    graph = run_cli(str(scenario), '--isolate', '--no-record', '--duration', '0.004',
                    '--out', str(tmp_path / 'graph'))
    assert graph.returncode == 3, graph.stdout + graph.stderr
    [line] = [ln for ln in graph.stderr.splitlines() if ln.startswith('run_scenario: ')]
    assert 'tripping: ended in fault state motor_over_current (first fault at t = ' in line
    assert line.endswith('unexpected: motor_over_current')
    headless = run_cli(str(scenario), '--headless', '--duration', '0.004', '--out', str(tmp_path / 'h'))
    assert headless.returncode == 3, headless.stdout + headless.stderr
    # the same first fault, at the same sim time, in both
    assert line.split(': ', 1)[1] in headless.stderr


def test_a_scenario_that_expects_its_fault_passes_and_says_so(tmp_path):
    scenario = _tripping_scenario(tmp_path, 'expect_faults: [motor_over_current]\n')
    result = run_cli(str(scenario), '--headless', '--duration', '0.004', '--out', str(tmp_path / 'h'))
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'ended in fault state motor_over_current' in result.stdout
    assert 'expected by the scenario (expect_faults: motor_over_current)' in result.stdout
    bad = _tripping_scenario(tmp_path, 'expect_faults: [overheat]\n')
    refused = run_cli(str(bad), '--headless', '--out', str(tmp_path / 'b'))
    assert refused.returncode == 2
    assert "expect_faults[0]: unknown fault kind 'overheat'" in refused.stderr


def test_a_paused_run_holds_until_resumed_and_records_the_same_samples(recorded_run, tmp_path,
                                                                        ros_session):
    """--pause-at holds the plant at a sim time until /scenario_runner/resume is called (the
    service is up only while held); the run then goes on to the same data as without a pause."""
    from std_srvs.srv import Trigger
    from drive_testing.block_bags import recorded_samples
    from drive_testing.harness import call_until_answered
    out = tmp_path / 'paused'
    process = subprocess.Popen(
        [sys.executable, '-m', 'drive_bringup.runner_cli', SCENARIO, '--duration', str(DURATION),
         '--pause-at', '0.005', '--domain-id', str(ros_session.domain_id), '--out', str(out)],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        client = ros_session.node('resumer').create_client(Trigger, '/scenario_runner/resume')
        wait_until(lambda: client.service_is_ready() or process.poll() is not None, 120.0,
                   what='the run held at 0.005 s')
        assert process.poll() is None, process.stdout.read()
        response = call_until_answered(client, Trigger.Request(), 60.0,
                                       stop=lambda: process.poll() is not None, what='the resume call')
        assert response is not None, process.stdout.read()
        assert response.success and response.message == 'resumed at t = 0.005000 s'
        output, _ = process.communicate(timeout=300)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == 0, output
    assert 'paused at t = 0.005000 s: resume with ros2 service call /scenario_runner/resume' in output
    assert recorded_samples(out / 'bag') == recorded_samples(recorded_run[0] / 'bag')


def test_a_pause_outside_the_run_or_headless_is_refused_before_anything_starts(tmp_path):
    late = run_cli(SCENARIO, '--duration', str(DURATION), '--pause-at', '0.5', '--out', str(tmp_path / 'a'))
    assert late.returncode == 2 and '--pause-at 0.5: must be inside the run' in late.stderr
    headless = run_cli(SCENARIO, '--headless', '--pause-at', '0.005', '--out', str(tmp_path / 'b'))
    assert headless.returncode == 2 and 'cannot be combined with --headless' in headless.stderr
    assert not (tmp_path / 'a').exists() and not (tmp_path / 'b').exists()
