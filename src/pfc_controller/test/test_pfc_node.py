"""pfc_controller node started as ``ros2 run`` would: lockstep answers and runtime parameters."""
from __future__ import annotations

import threading

import pytest

from drive_common.telemetry_blocks import expand
from drive_testing.harness import answer_of, send_until_answered, wait_for_subscribers
from drive_common.waiting import wait_until

pytestmark = pytest.mark.ros


def test_node_answers_each_step_and_takes_parameters(start_node, ros_session):
    from rclpy.parameter import Parameter
    from rclpy.parameter_client import AsyncParameterClient

    from drive_common import topics
    from drive_common.conversions import time_msg
    from drive_testing.block_probe import BlockSamples, message_bits
    from dtc_msgs.msg import DutyCommand, PfcMeasurement, PfcStatus, PfcStatusBlock

    # live_period 0: pfc/status carries every sample (default: 1 ms of sim time).
    process = start_node('pfc_controller', 'pfc_controller',
                         parameters={'voltage_reference': 85.0, 'voltage_reference_ramp_rate': 0.0,
                                     'telemetry.live_period': 0.0})
    node = ros_session.node('pfc_test_driver')
    lock = threading.Lock()
    duties, statuses = {}, {}

    def on_duty(msg):
        with lock:
            duties[msg.step] = msg

    def on_status(msg):
        with lock:
            statuses[msg.step] = msg

    node.create_subscription(DutyCommand, topics.DUTY_COMMAND, on_duty, topics.LOCKSTEP_QOS)
    node.create_subscription(PfcStatus, topics.PFC_STATUS, on_status, topics.LOCKSTEP_QOS)
    pub = node.create_publisher(PfcMeasurement, topics.PFC_MEASUREMENT, topics.LOCKSTEP_QOS)
    blocks = BlockSamples(node, PfcStatusBlock, topics.PFC_STATUS_BLOCK)
    sent = {}
    wait_for_subscribers(node, topics.PFC_MEASUREMENT, timeout=20.0)
    wait_until(lambda: node.count_publishers(topics.PFC_STATUS) >= 1, 20.0, what='status publisher')

    def send(step: int, hold_after: bool = False) -> None:
        msg = PfcMeasurement(step=step, rectified_voltage=20.0, inductor_current=1.0,
                             output_voltage=75.0)
        msg.header.stamp = time_msg(step * 12.5e-6)
        sent[step] = message_bits(msg)       # as a block records it: without the hold mark
        msg.hold_after = hold_after
        send_until_answered(lambda: pub.publish(msg), lambda: step in duties and step in statuses,
                            what=f'answer to step {step}')

    for step in (7, 8, 9):
        send(step)
    with lock:
        duty, status = duties[9], statuses[9]
    assert duty.header.stamp == time_msg(9 * 12.5e-6)
    assert duty.enable and 0.0 <= duty.duty <= 0.95
    assert status.enabled and status.voltage_reference == pytest.approx(85.0)
    assert status.duty == pytest.approx(duty.duty)
    assert status.input_per_unit == pytest.approx(20.0 / 70.71)

    client = AsyncParameterClient(node, 'pfc_controller')
    assert client.wait_for_services(timeout_sec=10.0)

    ok = answer_of(lambda: client.set_parameters([Parameter('voltage_reference', value=90.0),
                                                  Parameter('enable', value=False)]), 'set')
    assert all(r.successful for r in ok.results), ok
    send(10, hold_after=True)
    assert not statuses[10].enabled and not duties[10].enable and duties[10].duty == 0.0
    assert statuses[10].voltage_reference == pytest.approx(90.0)
    # pfc/status_block (the partial block flushed after the sample before the hold): every
    # answered sample once, with the measurement it acted on and the command it sent, bit-exact.
    wait_until(lambda: len(blocks.records) >= 4, 10.0, what='status blocks of steps 7..10')
    assert [status.step for status, _, _ in blocks.records] == [7, 8, 9, 10]
    for status, measurement, duty in blocks.records:
        assert message_bits(measurement) == sent[status.step]
        assert message_bits(duty) == message_bits(duties[status.step])
        assert message_bits(status) == message_bits(statuses[status.step])

    bad = answer_of(lambda: client.set_parameters([Parameter('voltage_kp', value=-1.0)]), 'set')
    assert not bad.results[0].successful and 'voltage_kp' in bad.results[0].reason
    bad = answer_of(lambda: client.set_parameters([Parameter('voltage_reference', value=150.0)]), 'set')
    assert not bad.results[0].successful and 'over_voltage_limit' in bad.results[0].reason
    got = answer_of(lambda: client.get_parameters(['voltage_kp', 'voltage_reference']), 'get')
    assert got.values[0].double_value == pytest.approx(0.1736)
    assert got.values[1].double_value == pytest.approx(90.0)
    assert process.alive(), process.output()


def _test_plant(start_node, ros_session):
    """A pfc_controller (every sample on the live topic) and a test node in the plant's place:
    (its status blocks as received, answer(step): send the measurement of step until answered)."""
    from drive_common import topics
    from drive_common.conversions import time_msg
    from drive_testing.block_probe import BlockSamples
    from dtc_msgs.msg import DutyCommand, PfcMeasurement, PfcStatusBlock

    start_node('pfc_controller', 'pfc_controller', parameters={'telemetry.live_period': 0.0})
    node = ros_session.node('pfc_test_plant')
    duties = set()
    node.create_subscription(DutyCommand, topics.DUTY_COMMAND, lambda m: duties.add(m.step),
                             topics.LOCKSTEP_QOS)
    pub = node.create_publisher(PfcMeasurement, topics.PFC_MEASUREMENT, topics.LOCKSTEP_QOS)
    blocks = BlockSamples(node, PfcStatusBlock, topics.PFC_STATUS_BLOCK)
    wait_for_subscribers(node, topics.PFC_MEASUREMENT, timeout=20.0)

    def answer(step: int, hold_after: bool = False) -> None:
        msg = PfcMeasurement(step=step, output_voltage=75.0, hold_after=hold_after)
        msg.header.stamp = time_msg(step * 12.5e-6)      # consecutive samples: one block
        send_until_answered(lambda: pub.publish(msg), lambda: step in duties,
                            what=f'answer to step {step}')
    return blocks, answer


def test_the_block_ends_at_the_plants_hold_and_an_outsider_cannot_end_it(start_node, ros_session,
                                                                         ros_domain):
    """The partial status block goes out after the bound plant's sample marked ``hold_after``,
    and only then: an outsider publishing marked measurements (a ``ros2 topic pub -r 5``) is
    ignored, so the block boundaries are the plant's alone."""
    from drive_common import topics
    from drive_testing.harness import RosSession
    from dtc_msgs.msg import PfcMeasurement

    blocks, answer = _test_plant(start_node, ros_session)
    answer(1)                                # the controller is bound to this plant
    outsider = RosSession(ros_domain)
    try:
        stray_node = outsider.node('stray_cli')
        stray = stray_node.create_publisher(PfcMeasurement, topics.PFC_MEASUREMENT, topics.LOCKSTEP_QOS)
        sent = []
        stray_node.create_timer(0.1, lambda: sent.append(
            stray.publish(PfcMeasurement(step=999, hold_after=True))))
        wait_until(lambda: len(sent) >= 3, 30.0, what='the outsider publishing')
        answer(2)
        answer(3, hold_after=True)
        wait_until(lambda: len(blocks.records) >= 3, 30.0, what='the partial block of steps 1..3')
        assert [status.step for status, _, _ in blocks.records] == [1, 2, 3]
        assert len(blocks.blocks) == 1, 'an outsider ended a block'
    finally:
        outsider.close()


def test_a_stall_between_samples_does_not_split_a_block(start_node, ros_session):
    """Block boundaries do not depend on wall time: a plant stalled between two samples (a
    loaded machine) leaves one block, which ends at the plant's hold."""
    import time

    blocks, answer = _test_plant(start_node, ros_session)
    answer(1)
    time.sleep(1.5)       # the stimulus: a stalled plant (not a wait for a condition)
    answer(2)
    answer(3, hold_after=True)
    wait_until(lambda: len(blocks.records) >= 3, 30.0, what='the partial block at the hold')
    assert [status.step for status, _, _ in blocks.records] == [1, 2, 3]
    assert [[status.step for status, _, _ in expand(block)] for block in blocks.blocks] == [[1, 2, 3]]
