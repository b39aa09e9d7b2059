"""Every executable reads standard ROS 2 parameter files and resolves package:// itself;
a bad file, a bad URI or a bad value ends it with exit code 2 and one line."""
from __future__ import annotations

import subprocess
import sys

import pytest
from rclpy.serialization import serialize_message

from drive_logger import qos_yaml
from drive_logger.bag_writer import BagWriter
from drive_logger.message_definitions import type_definition
from drive_testing.harness import isolated_env
from dtc_msgs.msg import DriveMeasurement, GateCommand

pytestmark = pytest.mark.ros

MOTOR = 'package://bldc_plant_sim/motors/ozturk_bldc.yaml'
TABLE = 'package://bldc_plant_sim/motors/ozturk_bldc_nonideal_backemf.csv'

# node executable -> (package, a string parameter for the bad URI, a bad value)
NODES = {
    'plant': ('bldc_plant_sim', 'motor.file', ('dc_link.voltage', -5.0)),
    'dtc_controller': ('dtc_controller', 'backemf_table_path', ('torque_band', -1.0)),
    'pfc_controller': ('pfc_controller', None, ('voltage_kp', -1.0)),
    'recorder': ('drive_logger', 'output', ('compression', 'zip')),
    'replay': ('drive_logger', 'bag', ('rate', 'fast')),
    'hysteresis_current_controller': ('drive_examples', None, ('current_band', -1.0)),  # your own
}


def _params_file(path, node, values) -> str:
    import yaml
    path.write_text(yaml.safe_dump({node: {'ros__parameters': values}}))
    return str(path)


def _one_line_error(code, output, *expected):
    lines = [line for line in output.splitlines() if line.strip()]
    assert code == 2, output
    assert len(lines) == 1 and 'error' in lines[0] and 'Traceback' not in output, output
    for text in expected:
        assert text in lines[0], output


@pytest.mark.parametrize('node', sorted(NODES))
def test_node_reports_a_bad_params_file_uri_or_value_in_one_line(start_node, tmp_path, node):
    package, uri_key, (bad_key, bad_value) = NODES[node]
    broken = tmp_path / 'broken.yaml'
    broken.write_text(f'{node}:\n  ros__parameters: [1, 2\n')
    cases = [([str(tmp_path / 'missing.yaml')], 'missing.yaml'), ([str(broken)], 'broken.yaml'),
             ([_params_file(tmp_path / 'value.yaml', '/**', {bad_key: bad_value})], bad_key)]
    if uri_key:
        cases.append(([_params_file(tmp_path / 'uri.yaml', node, {uri_key: 'package://no_such_pkg/x'})],
                      'no_such_pkg'))
    for files, expected in cases:
        process = start_node(package, node, params_files=files)
        _one_line_error(process.process.wait(timeout=60), process.output(), expected)


def test_nodes_read_standard_params_files_and_resolve_package_uris(start_node, ros_session, tmp_path):
    """A plant and a controller configured only by files with package:// names start and answer."""
    from rclpy.parameter import parameter_value_to_python
    from rclpy.parameter_client import AsyncParameterClient

    from drive_common.waiting import wait_until
    start_node('bldc_plant_sim', 'plant', params_files=[
        _params_file(tmp_path / 'plant.yaml', 'plant', {'motor': {'file': MOTOR}, 'run_until': 0.0})])
    start_node('dtc_controller', 'dtc_controller', params_files=[
        _params_file(tmp_path / 'dtc.yaml', '/**', {'backemf_table_path': TABLE})])
    probe = ros_session.node('probe')
    for node, name, value in (('plant', 'motor.file', MOTOR), ('dtc_controller', 'backemf_table_path', TABLE)):
        client = AsyncParameterClient(probe, f'/{node}')
        assert client.wait_for_services(timeout_sec=60.0), f'{node} did not start'
        future = client.get_parameters([name])
        wait_until(future.done, 10.0, what=f'{node} {name}')
        assert parameter_value_to_python(future.result().values[0]) == value


def _bag(path):
    writer = BagWriter(path)
    meas = writer.add_topic('/drive/measurement', type_definition('dtc_msgs/msg/DriveMeasurement'),
                            [qos_yaml.profile()])
    gate = writer.add_topic('/drive/gate_command', type_definition('dtc_msgs/msg/GateCommand'),
                            [qos_yaml.profile()])
    for k in range(3):
        writer.write(meas, serialize_message(DriveMeasurement(step=k)), k, k)
        writer.write(gate, serialize_message(GateCommand(step=k)), k, k)
    writer.close()
    return str(path)


def _run(argv, domain, timeout=120):
    result = subprocess.run([sys.executable, '-m', *argv], capture_output=True, text=True,
                            env=isolated_env(domain), timeout=timeout)
    return result.returncode, result.stdout + result.stderr


def test_compare_replay_reports_bad_input_in_one_line(ros_domain, tmp_path):
    bag = _bag(tmp_path / 'bag')
    base = ['drive_logger.compare_replay', bag, '--executable', 'dtc_controller', '--timeout', '5']
    _one_line_error(*_run(base + ['--params-file', str(tmp_path / 'missing.yaml')], ros_domain),
                    'missing.yaml')
    standard = _params_file(tmp_path / 'dtc.yaml', 'dtc_controller',
                            {'backemf_table_path': 'package://no_such_pkg/t.csv'})
    _one_line_error(*_run(base + ['--params-file', standard], ros_domain), 'no_such_pkg')
    _one_line_error(*_run(base + ['-p', 'torque_band:=-1.0'], ros_domain), 'torque_band')


def test_run_scenario_reports_bad_input_in_one_line(ros_domain, tmp_path):
    base = ['drive_bringup.runner_cli', 'two_phase_six_switch_torque_step', '--out', str(tmp_path / 'o')]
    _one_line_error(*_run(base + ['--params-file', str(tmp_path / 'missing.yaml')], ros_domain),
                    'missing.yaml')
    uri = _params_file(tmp_path / 'uri.yaml', 'dtc_controller',
                       {'backemf_table_path': 'package://no_such_pkg/t.csv'})
    _one_line_error(*_run(base + ['--params-file', uri], ros_domain), 'no_such_pkg', 'uri.yaml')
    value = _params_file(tmp_path / 'value.yaml', 'plant', {'dc_link': {'voltage': -5.0}})
    _one_line_error(*_run(base + ['--params-file', value], ros_domain), 'dc_link.voltage', 'value.yaml')
