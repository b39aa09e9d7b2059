"""The drive nodes stamp their /parameter_events with sim time.

rclpy stamps a parameter event with the node's clock (wall time); the plant
re-stamps it with its current sim time, a lockstep controller with the stamp
of the last measurement it answered (drive_common.ros_parameters.SimStampedEvents).
A change at a hold is thus stamped with the hold's sim time, whatever the
wall clock or the load, and the recorder logs it there (docs/architecture.md "Bags").
"""
from __future__ import annotations

import pytest
from rcl_interfaces.msg import ParameterEvent
from rclpy.action import ActionClient
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from drive_bringup.scenario import find_scenario, load_scenario
from drive_common import topics
from drive_common.run_goal import run_to
from drive_common.conversions import time_msg
from drive_common.waiting import wait_until
from drive_testing.harness import answer_of
from drive_logger.message_definitions import is_sim_stamp
from dtc_msgs.action import Run
from dtc_msgs.msg import DriveMeasurement

pytestmark = pytest.mark.ros

SCENARIO = 'two_phase_six_switch_torque_step'
HOLD = 0.001          # s: the plant holds here after the goal (30 samples at 30 kHz)
EVENTS_QOS = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.VOLATILE)


def _ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def _set(client, name, value) -> None:
    """Set one parameter (asked again if the reply is lost: a repeat is stamped alike)."""
    result = answer_of(lambda: client.set_parameters([Parameter(name, value=value)]),
                       f'set {name}').results[0]
    assert result.successful, result.reason


def test_a_change_at_a_hold_is_stamped_with_the_hold_sim_time(start_node, ros_session):
    scenario = load_scenario(find_scenario(SCENARIO))
    start_node('bldc_plant_sim', 'plant', parameters=scenario.overrides['plant'])
    start_node('dtc_controller', 'dtc_controller', parameters=scenario.overrides['dtc_controller'])
    probe = ros_session.node('event_probe')
    events: list[ParameterEvent] = []
    measurements: list[DriveMeasurement] = []
    probe.create_subscription(ParameterEvent, '/parameter_events', events.append, EVENTS_QOS)
    probe.create_subscription(DriveMeasurement, topics.DRIVE_MEASUREMENT, measurements.append,
                              topics.LOCKSTEP_QOS)
    clients = {n: AsyncParameterClient(probe, f'/{n}') for n in ('plant', 'dtc_controller')}
    for name, client in clients.items():
        assert client.wait_for_services(timeout_sec=60.0), f'{name}: no parameter services'
    wait_until(lambda: probe.count_publishers(topics.DRIVE_MEASUREMENT) >= 1
               and probe.count_subscribers('/parameter_events') >= 1, 30.0, what='graph')

    def changes_of(node: str) -> list[ParameterEvent]:
        return [e for e in events if e.node == node and e.changed_parameters]

    # Before the first goal: the plant is at sim time 0; the controller has answered nothing
    # yet, so its event keeps rclpy's stamp (its wall clock: the recorder's fallback rule).
    _set(clients['plant'], 'dc_link.voltage', 47.0)
    _set(clients['dtc_controller'], 'torque_reference', 0.3)
    wait_until(lambda: changes_of('/plant') and changes_of('/dtc_controller'), 30.0, what='events')
    assert _ns(changes_of('/plant')[-1].stamp) == 0
    assert not is_sim_stamp(_ns(changes_of('/dtc_controller')[-1].stamp))

    action = ActionClient(probe, Run, topics.RUN_ACTION)
    wait_until(action.server_is_ready, 30.0, what='plant/run')
    result = run_to(action, HOLD)
    assert result.success, result.message
    samples = round(HOLD * 30000)
    wait_until(lambda: len(measurements) >= samples, 30.0, what='measurements')
    last = measurements[-1]
    assert last.step == samples - 1                 # held at T: sample T not yet measured

    # A change at the hold T: the plant's event is stamped T, the controller's with the
    # sample it answered last (T minus one sample period); both act from the sample at T.
    events.clear()
    _set(clients['plant'], 'dc_link.voltage', 48.0)
    _set(clients['dtc_controller'], 'torque_reference', 0.35)
    wait_until(lambda: changes_of('/plant') and changes_of('/dtc_controller'), 30.0, what='events')
    assert changes_of('/plant')[-1].stamp == time_msg(result.final_time)
    assert result.final_time == pytest.approx(HOLD, abs=1e-9)
    assert changes_of('/dtc_controller')[-1].stamp == last.header.stamp
    assert _ns(time_msg(HOLD)) - _ns(last.header.stamp) == pytest.approx(1e9 / 30000, abs=2)


def test_an_rclpy_without_the_event_publisher_is_refused_not_left_on_wall_time():
    from drive_common.ros_parameters import SimStampedEvents

    class NoPublisher:
        def get_name(self):
            return 'plant'

    with pytest.raises(RuntimeError, match='plant: .*cannot be stamped with sim time'):
        SimStampedEvents.install(NoPublisher(), lambda: 0.0)


def test_events_are_restamped_and_a_missing_sim_time_keeps_the_node_clock():
    from builtin_interfaces.msg import Time
    from drive_common.ros_parameters import SimStampedEvents
    sent = []

    class Publisher:
        publish = staticmethod(sent.append)

    now = [None]
    events = SimStampedEvents(Publisher(), lambda: now[0])
    wall = ParameterEvent(stamp=Time(sec=1_795_000_000, nanosec=7))
    events.publish(wall)
    assert sent[-1].stamp == Time(sec=1_795_000_000, nanosec=7)
    now[0] = 0.0094
    events.publish(ParameterEvent(stamp=Time(sec=1_795_000_000)))
    assert sent[-1].stamp == Time(sec=0, nanosec=9_400_000)
    now[0] = Time(sec=0, nanosec=9_366_667)                  # a sample's stamp
    events.publish(ParameterEvent(stamp=Time(sec=1_795_000_000)))
    assert sent[-1].stamp == Time(sec=0, nanosec=9_366_667)
