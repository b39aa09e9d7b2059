"""The default bag as a viewer reads it: Foxglove's JavaScript reader stack (test/js: @mcap/core,
@mcap/support, @foxglove/rosmsg, @foxglove/rosmsg2-serialization, run with node) decodes every
message of a scenario's bag; /plant/state is a time series at the viewer rate (1 ms of sim time)
over the whole run; the full-rate export (drive_logger export --to mcap) has one message per
sample with contiguous steps. Needs node and npm (fails without them when CI=true, else skips)."""
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

pytestmark = pytest.mark.ros

JS = Path(__file__).resolve().parent / 'js'
SCENARIO = 'two_phase_six_switch_torque_step'
DURATION = 0.012      # s
TICK = 1 / 30000      # s: the scenario's plant tick and controller period
VIEWER_PERIOD = 1e-3  # s: the recorder's default viewer_period


@pytest.fixture(scope='module')
def node_reader():
    """Command prefix that runs test/js/read_bag.mjs (npm ci first when node_modules is missing)."""
    node, npm = shutil.which('node'), shutil.which('npm')
    if not node or not npm:
        message = 'node and npm are needed to read bags with the Foxglove JavaScript stack'
        if os.environ.get('CI') == 'true':
            pytest.fail(message)
        pytest.skip(message)
    if not (JS / 'node_modules').is_dir():
        result = subprocess.run([npm, 'ci', '--no-audit', '--no-fund'], cwd=JS, capture_output=True,
                                text=True, timeout=600)
        assert result.returncode == 0, result.stderr
    return [node, str(JS / 'read_bag.mjs')]


def read_with_foxglove(node_reader, mcap: Path, topic: str, field: str) -> dict:
    result = subprocess.run([*node_reader, str(mcap), topic, field], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout)


@pytest.fixture(scope='module')
def default_bag(tmp_path_factory):
    out = tmp_path_factory.mktemp('viewer') / 'out'
    result = subprocess.run([sys.executable, '-m', 'drive_bringup.runner_cli', SCENARIO, '--duration',
                             str(DURATION), '--isolate', '--out', str(out)],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    return out / 'bag'


def test_foxglove_stack_plots_speed_of_the_default_bag(node_reader, default_bag):
    got = read_with_foxglove(node_reader, default_bag / 'bag_0.mcap', '/plant/state', 'mechanical_speed')
    meta = yaml.safe_load((default_bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert got['decoded'] == meta['message_count']           # every message decodes
    series = got['series']
    stride = round(VIEWER_PERIOD / TICK)
    # one sample per ms of sim time from t = 0 to the end of the run, logged at its stamp
    assert series['step'] == list(range(0, round(DURATION / TICK) + 1, stride))
    assert series['log_time'] == series['stamp']
    assert all(abs(b - a - VIEWER_PERIOD * 1e9) <= 1 for a, b in zip(series['stamp'], series['stamp'][1:]))
    assert all(isinstance(v, (int, float)) for v in series['value']) and series['value'][0] == 30.0  # initial speed
    assert {'/plant/state_block', '/dtc/status_block', '/dtc/status', '/clock'} <= set(got['counts'])


def test_foxglove_stack_reads_one_message_per_sample_of_the_full_rate_export(node_reader, default_bag,
                                                                            tmp_path):
    out = tmp_path / 'viewer'
    result = subprocess.run([sys.executable, '-m', 'drive_logger.export', str(default_bag), '--to', 'mcap',
                             str(out)], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    samples = round(DURATION / TICK)
    plant = read_with_foxglove(node_reader, out / 'viewer_0.mcap', '/plant/state', 'electromagnetic_torque')
    assert plant['series']['step'] == list(range(samples + 1))           # t_0 .. t_N, contiguous
    assert plant['series']['log_time'] == plant['series']['stamp']
    status = read_with_foxglove(node_reader, out / 'viewer_0.mcap', '/dtc/status', 'torque_estimate')
    assert status['series']['step'] == list(range(samples))
    assert status['counts']['/drive/measurement'] == status['counts']['/drive/gate_command'] == samples
    assert not any(topic.endswith('_block') for topic in status['counts'])
