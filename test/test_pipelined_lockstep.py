"""Pipelined lockstep with ``computation_delay``, through real ROS processes.

- Recorded bags of the pipelined graph (plant + dtc_controller; plant +
  dtc_controller + pfc_controller, multi-rate) equal the headless
  co-simulation with the same delay step by step, across goals with holds
  (and a parameter change) between them; the sequential ROS schedule
  (``pipelined: false``) gives the same bag.
- A goal cancelled mid-run drains the pipeline: the next goal continues the
  headless trajectory.
- A controller killed mid-run: the plant enters the safe state, reports it on
  /diagnostics and in the goal's result, and does not hang.
"""
import math
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.action import ActionClient

from drive_bringup.headless import run_headless
from drive_bringup.runner import GraphRunner
from drive_bringup.scenario import Event, find_scenario, load_scenario
from drive_common import topics
from drive_common.action_goals import polling_wait, within
from drive_common.run_goal import run_goal_result, send_run_goal
from drive_common.waiting import wait_until
from dtc_msgs.action import Run
from dtc_msgs.msg import PlantState

pytestmark = pytest.mark.ros

STATE_FIELDS = ('step', 'phase_current', 'electromagnetic_torque', 'mechanical_speed',
                'rotor_angle', 'applied_switch_on')
# Not boost_duty / boost_switch_enabled (the latched command): the headless record at
# tick k is taken after the latch, plant/state before it.
PFC_FIELDS = ('inductor_current', 'grid_current', 'dc_link_voltage', 'rectified_voltage')


def _delayed(name: str, duration: float, pipelined: bool, event: Event | None = None, **plant):
    scenario = load_scenario(find_scenario(name)).with_parameters(
        'test', {'plant': {'computation_delay': True, 'pipelined': pipelined, **plant}})
    if event is not None:
        scenario.events.append(event)
    return scenario.shortened(duration)


def _record(scenario, out, domain: int) -> dict:
    from drive_analysis.bag_columns import load_columns
    result = GraphRunner(scenario, out, domain_id=domain, progress=lambda _line: None).run()
    assert result.final_step == round(scenario.duration / scenario.node_parameters['plant']['base_tick'])
    return load_columns(str(result.bag))


def _assert_equal_to_headless(columns: dict, scenario, fields) -> np.ndarray:
    headless = run_headless(scenario).arrays()
    state = columns['/plant/state']
    assert np.array_equal(state['step'], headless['plant/state.step'])   # every sample, in order
    for name in fields:
        assert np.array_equal(state[name], headless[f'plant/state.{name}']), name
    status = columns['/dtc/status']
    assert np.array_equal(status['step'], headless['dtc/status.step'])
    assert np.array_equal(status['torque_estimate'], headless['dtc/status.torque_estimate'])
    return state


def _hold_where_the_command_changes(scenario) -> Event:
    """An event (a hold between two goals) at a tick T whose last due command, T - 1,
    differs from the one before: a pipeline not drained at the hold would show."""
    commands = run_headless(scenario, record_every=1).trajectory.commands
    tick = scenario.node_parameters['plant']['base_tick']
    hold = next(k for k in range(100, len(commands)) if commands[k - 1][0].switch_on
                != commands[k - 2][0].switch_on)
    torque = scenario.node_parameters['dtc_controller']['torque_reference']
    return Event(time=hold * tick, node='dtc_controller', parameters={'torque_reference': torque})


@pytest.mark.parametrize('pipelined', [True, False])
def test_delayed_dtc_graph_equals_headless_across_holds(pipelined, ros_domain, tmp_path):
    # Three goals: held where the command has just changed, and at the torque step (9.4 ms).
    scenario = _delayed('two_phase_six_switch_torque_step', 0.012, pipelined)
    scenario.events.insert(0, _hold_where_the_command_changes(scenario))
    assert len(scenario.events) == 2 and scenario.events[0].time < scenario.events[1].time == 0.0094
    state = _assert_equal_to_headless(_record(scenario, tmp_path / 'out', ros_domain), scenario,
                                      STATE_FIELDS)
    # The delay shows: nothing is applied over the first sample, then the drive switches.
    assert not any(state['applied_switch_on'][1]) and np.ptp(state['phase_current'][:, 1]) > 0.5


def test_delayed_pfc_and_dtc_graph_equals_headless_across_a_hold(ros_domain, tmp_path):
    # PFC every base tick, DTC every second one; the second goal starts at an odd
    # step (241), where only the PFC controller is due. Ground truth at every tick
    # (the headless record at a hold is taken whether or not a state is due there).
    event = Event(time=241 * 1.25e-5, node='dtc_controller', parameters={'torque_reference': 0.3})
    scenario = _delayed('pfc_no_load_fig_3_5', 0.006, True, event, state_period=1.25e-5)
    columns = _record(scenario, tmp_path / 'out', ros_domain)
    state = _assert_equal_to_headless(columns, scenario, STATE_FIELDS + PFC_FIELDS)
    assert np.ptp(state['inductor_current']) > 0.2          # the boost conducts (0.28 A at 6 ms)
    headless = run_headless(scenario).arrays()
    pfc = columns['/pfc/status']
    kept = np.isin(pfc['step'], headless['pfc/status.step'])    # headless keeps every 2nd
    assert kept.sum() == len(headless['pfc/status.step'])
    assert np.array_equal(pfc['duty'][kept], headless['pfc/status.duty'])


def _client(ros_session):
    """(node, Run action client, plant/state list) once the plant serves and publishes."""
    node = ros_session.node('pipelined_test_client')
    states = []
    subscription = node.create_subscription(PlantState, topics.PLANT_STATE, states.append, topics.STREAM_QOS)
    action = ActionClient(node, Run, topics.RUN_ACTION)
    wait_until(action.server_is_ready, 30.0, what='plant/run action server')
    wait_until(lambda: subscription.get_publisher_count() >= 1, 30.0,
               what='plant/state subscription matched')
    return node, action, states


def _send(action, target: float):
    handle = send_run_goal(action, target)
    assert handle.accepted
    return handle


def _result(handle):
    result = run_goal_result(handle, wait=within(polling_wait, 120.0))
    assert result is not None, 'no Run result in 120 s (the plant must not hang)'
    return result


def test_cancelled_goals_drain_the_pipeline_and_the_next_goal_continues(start_node, ros_session):
    # Three goals cancelled at wall-clock moments, then one to the end: the ground truth
    # is the uninterrupted headless run's (a cancel where the last two commands differ,
    # about one in three, shows a pipeline not drained at the cancel).
    scenario = _delayed('two_phase_six_switch_torque_step', 0.04, True)
    scenario.events.clear()
    base_tick = scenario.node_parameters['plant']['base_tick']
    start_node('dtc_controller', 'dtc_controller',
               parameters=dict(scenario.overrides['dtc_controller']))
    start_node('bldc_plant_sim', 'plant', parameters=dict(scenario.overrides['plant']))
    _, action, states = _client(ros_session)     # matched: sample 0 reaches states
    cancelled_at = []
    for _ in range(3):
        start = states[-1].step if states else 0
        handle = _send(action, 10.0)
        wait_until(lambda: states and states[-1].step > start + 30, 60.0, what='run under way')
        handle.cancel_goal_async()
        cancelled = _result(handle)
        assert 'cancelled at' in cancelled.message, cancelled.message
        cancelled_at.append(cancelled.final_step)
    assert cancelled_at == sorted(set(cancelled_at)), cancelled_at
    # The last goal runs on past the cancels: 0.3 s (9000 samples), or a whole 0.1 s more when a
    # loaded machine let a goal run long before its reply (or its cancel) got through.
    scenario.duration = max(0.3, math.ceil(cancelled_at[-1] * base_tick * 10.0 + 1.0) / 10.0)
    last = round(scenario.duration / base_tick)
    assert cancelled_at[-1] < last, (cancelled_at, last)
    finished = _result(_send(action, scenario.duration))
    assert finished.success and finished.final_step == last, finished.message
    wait_until(lambda: states[-1].step == last, 30.0, what='last state')
    headless = run_headless(scenario, record_every=1).trajectory
    by_step = {s.step: s for s in states}
    compared = 0
    for step, truth in zip(headless.steps, headless.states):
        if step in by_step:
            assert list(by_step[step].phase_current) == list(truth.phase_current), step
            assert list(by_step[step].applied_switch_on) == list(truth.applied_switch_on), step
            compared += 1
    assert compared >= 250 and last in by_step   # every sample (or the live topic's decimation)


def test_controller_killed_mid_run_gives_safe_state_and_the_plant_does_not_hang(
        start_node, ros_session):
    plant_params = {'motor.file': 'ozturk_bldc', 'dc_link.voltage': 10.0,
                    'computation_delay': True, 'command_timeout': 3.0, 'startup_timeout': 5.0,
                    'load.mode': 'dynamometer', 'load.speed': 20.0}
    responder = start_node('drive_testing', 'fixed_responder',
                           parameters={'switch_on': [1.0, 0.0, 0.0, 1.0, 0.0, 0.0]})
    start_node('bldc_plant_sim', 'plant', parameters=plant_params)
    node, action, states = _client(ros_session)
    diagnostics = []
    node.create_subscription(DiagnosticArray, topics.DIAGNOSTICS, diagnostics.append, 10)
    wait_until(lambda: node.count_publishers(topics.DIAGNOSTICS) >= 1, 30.0, what='diagnostics')
    handle = _send(action, 0.25)                 # 10000 samples: still running at the kill
    wait_until(lambda: states and states[-1].step > 100, 60.0, what='run under way')
    assert any(states[-1].applied_switch_on)
    responder.process.kill()
    responder.process.wait(timeout=10)
    started = time.monotonic()
    result = _result(handle)
    assert not result.success and 'safe state' in result.message, result.message
    assert 'no gate command for step' in result.message
    assert result.final_step == 10000                # went on to the target, switches off
    assert time.monotonic() - started < 100.0
    wait_until(lambda: states[-1].step == 10000, 10.0, what='last state')
    last = states[-1]
    assert last.safe_state and last.protection & PlantState.PROTECTION_COMMAND_TIMEOUT
    assert not any(last.applied_switch_on)
    wait_until(lambda: any('safe state' in s.message for d in diagnostics for s in d.status),
               10.0, what='safe-state diagnostic')


GOALS_PER_MODE = 120      # short goals per schedule (pipelined, sequential): 240 in all


def test_many_short_goals_all_end_pipelined_and_sequential(start_node, ros_session):
    # Every goal ends with its result (or aborts within the plant's own timeouts): none hangs.
    # One plant + fixed_responder serve every goal; pipelined is changed at a hold.
    from test_plant_lockstep import PlantClient
    start_node('drive_testing', 'fixed_responder', parameters={'switch_on': [1.0, 0.0, 0.0, 1.0, 0.0, 0.0]})
    start_node('bldc_plant_sim', 'plant', parameters={
        'motor.file': 'ozturk_bldc', 'dc_link.voltage': 10.0, 'computation_delay': True,
        'load.mode': 'dynamometer', 'load.speed': 20.0, 'command_timeout': 10.0})
    client = PlantClient(ros_session)
    tick, step = 25e-6, 0
    for pipelined in (True, False):
        assert client.set(pipelined=pipelined)[0].successful
        for goal in range(GOALS_PER_MODE):
            ticks = 1 + goal % 7                     # 1..7 ticks: ends on and off due samples
            step += ticks
            relative = goal % 2 == 0
            # A generous bound: a goal that never ends raises WaitTimeout here.
            result = client.run(ticks * tick if relative else step * tick, relative=relative,
                                timeout=120.0)
            assert result.success and result.final_step == step, (pipelined, goal, result.message)
            assert result.end_state == 'ended normally'
