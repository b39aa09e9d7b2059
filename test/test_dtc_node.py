"""The dtc_controller node through ROS (node, parameters, bad input).

- Started as ``ros2 run`` would, it answers each drive measurement with a
  gate command of the same step and a status.
- References act at the next sample; an out-of-range value is rejected with
  a reason and the old value kept; a mode change re-initialises cleanly.
- A missing or malformed back-EMF table stops the node at start with a
  message naming the file and the problem (it never runs half-configured).
"""
import math
import subprocess
import sys

import pytest
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient

from drive_common import topics
from drive_testing.harness import answer_of, send_until_answered, wait_for_subscribers
from drive_common.waiting import wait_until
from dtc_msgs.msg import DriveMeasurement, DtcStatus, GateCommand

pytestmark = pytest.mark.ros


@pytest.fixture(scope='module')
def backemf_table(tmp_path_factory):
    path = tmp_path_factory.mktemp('tables') / 'ozturk_bldc.csv'
    subprocess.run([sys.executable, '-m', 'bldc_plant_sim.backemf_generator', '--motor',
                    'ozturk_bldc', '-o', str(path)], check=True, capture_output=True, timeout=120)
    return path


def _measurement(step: int, angle: float) -> DriveMeasurement:
    msg = DriveMeasurement(step=step, dc_link_voltage=56.57, midpoint_voltage=28.28,
                           encoder_angle=angle, mechanical_speed=30.0, hall_code=1)
    msg.phase_current = [2.0, -2.0, 0.0]
    msg.header.stamp.nanosec = 25_000 * step
    return msg


def test_answers_each_step_and_applies_runtime_changes(start_node, ros_session, backemf_table):
    start_node('dtc_controller', 'dtc_controller',
               parameters={'backemf_table_path': str(backemf_table), 'torque_reference': 0.5,
                           'telemetry.live_period': 0.0})   # dtc/status: every sample
    node = ros_session.node('dtc_probe')
    gates, statuses = [], []
    pub = node.create_publisher(DriveMeasurement, topics.DRIVE_MEASUREMENT, topics.LOCKSTEP_QOS)
    node.create_subscription(GateCommand, topics.GATE_COMMAND, gates.append, topics.LOCKSTEP_QOS)
    node.create_subscription(DtcStatus, topics.DTC_STATUS, statuses.append, topics.STREAM_QOS)
    wait_for_subscribers(node, topics.DRIVE_MEASUREMENT, timeout=30.0)
    wait_until(lambda: node.count_publishers(topics.GATE_COMMAND) >= 1, 30.0)
    params = AsyncParameterClient(node, '/dtc_controller')
    assert params.wait_for_services(timeout_sec=30.0)

    def send(step):
        msg = _measurement(step, 0.3)
        send_until_answered(lambda: pub.publish(msg),
                            lambda: any(g.step == step for g in gates)
                            and any(s.step == step for s in statuses), what=f'answer to step {step}')
        return ([g for g in gates if g.step == step][-1], [s for s in statuses if s.step == step][-1])

    gate, status = send(7)
    assert gate.topology == GateCommand.TOPOLOGY_SIX_SWITCH and sum(gate.switch_on) == 2
    assert status.mode == 'two_phase_six_switch' and status.torque_reference == 0.5
    assert math.isfinite(status.torque_estimate)

    ok = answer_of(lambda: params.set_parameters([Parameter('torque_reference', value=0.8)]),
                   'set').results[0]
    assert ok.successful
    assert send(8)[1].torque_reference == 0.8

    bad = answer_of(lambda: params.set_parameters([Parameter('torque_band', value=-1.0)]), 'set').results[0]
    assert not bad.successful and 'torque_band' in bad.reason and 'range' in bad.reason
    kept = answer_of(lambda: params.get_parameters(['torque_band']), 'get').values[0]
    assert parameter_value_to_python(kept) == 0.001

    ok = answer_of(lambda: params.set_parameters([Parameter('mode', value='two_phase_four_switch')]),
                   'set').results[0]
    assert ok.successful
    gate, status = send(9)
    assert status.mode == 'two_phase_four_switch'
    assert gate.topology == GateCommand.TOPOLOGY_FOUR_SWITCH


@pytest.mark.parametrize('content, expected', [
    (None, 'no_such_table.csv'),
    ('# pole_pairs: 2\n# points: 3\ntheta_e,k_a\n0,1\n', 'malformed.csv'),
])
def test_bad_backemf_table_stops_the_node_with_the_reason(start_node, tmp_path, content, expected):
    path = tmp_path / expected
    if content is not None:
        path.write_text(content)
    process = start_node('dtc_controller', 'dtc_controller',
                         parameters={'backemf_table_path': str(path)})
    code = process.process.wait(timeout=30)
    output = process.output()
    assert code == 2, output
    assert expected in output and 'cannot start' in output, output


@pytest.mark.parametrize('package, executable, parameters, name', [
    ('dtc_controller', 'dtc_controller', {'torque_band': -1.0}, 'torque_band'),
    ('bldc_plant_sim', 'plant', {'dc_link.voltage': -5.0}, 'dc_link.voltage'),
    ('pfc_controller', 'pfc_controller', {'voltage_kp': -1.0}, 'voltage_kp'),
])
def test_out_of_range_start_up_value_is_refused_with_the_reason(start_node, package, executable,
                                                                 parameters, name):
    process = start_node(package, executable, parameters=parameters)
    code = process.process.wait(timeout=30)
    output = process.output()
    assert code == 2 and 'cannot start' in output and name in output, output
    assert 'Traceback' not in output, output
