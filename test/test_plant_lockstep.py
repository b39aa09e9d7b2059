"""The plant node as lockstep time master, through real ROS processes.

- A fixed-pattern responder answers the plant's measurements: the plant's
  ground truth equals the headless co-simulation's, sample for sample.
- The Run action stops exactly at the requested sim time and holds there.
- The commanding node killed mid-run: the plant applies the safe state,
  reports it, and still answers its action and its parameters.
- Bad parameters are rejected with a reason and the old value is kept.
- Ground truth travels in blocks (plant/state_block): every sample, bit-exact,
  partial blocks flushed at each hold; plant/state carries every M-th sample.
- The last measurement before each hold is marked hold_after (the controllers' block end).
"""
import math
import time

import pytest
from rclpy.action import ActionClient
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient

from bldc_plant_sim.core.cosim import CoSimulation
from bldc_plant_sim.core.plant import PlantCore
from drive_common.run_goal import run_to, send_run_goal
from drive_common import topics
from drive_common.telemetry import DEFAULT_BLOCK_SIZE
from drive_testing.fixed_commands import FixedGateCore
from drive_common.waiting import wait_until
from dtc_msgs.action import Run
from drive_testing.block_probe import BlockSamples, same_bits
from drive_testing.harness import answer_of
from dtc_msgs.msg import PlantState, PlantStateBlock

pytestmark = pytest.mark.ros

PATTERN = (True, False, False, True, False, False)   # a+ b-: vector V_ab
PLANT = {'motor.file': 'ozturk_bldc', 'dc_link.voltage': 10.0, 'motor.initial_speed': 20.0,
         'load.torque': 0.2, 'command_timeout': 10.0}


def _future_result(future, timeout: float, what: str):
    wait_until(future.done, timeout, what=what)
    return future.result()


class PlantClient:
    """Test-side view of a running plant: Run goals, parameters, recorded ground truth.

    states: every sample, from plant/state_block; live: plant/state (decimated);
    blocks: the block messages as received.
    """

    def __init__(self, session) -> None:
        self.node = session.node('plant_test_client')
        probe = BlockSamples(self.node, PlantStateBlock, topics.PLANT_STATE_BLOCK)
        self.states, self.blocks = probe.first, probe.blocks
        self.live: list = []
        live = self.node.create_subscription(PlantState, topics.PLANT_STATE, self.live.append,
                                             topics.STREAM_QOS)
        self.action = ActionClient(self.node, Run, topics.RUN_ACTION)
        self.params = AsyncParameterClient(self.node, '/plant')
        wait_until(lambda: self.action.server_is_ready(), 30.0, what='plant/run action server')
        assert self.params.wait_for_services(timeout_sec=30.0)
        # the state subscriptions matched the plant's publishers before the run starts
        wait_until(lambda: probe.subscription.get_publisher_count() >= 1 and live.get_publisher_count() >= 1,
                   30.0, what='plant/state_block and plant/state matched')

    def start(self, target: float, relative: bool = False):
        """Send a Run goal (a reply lost right after discovery is recovered); its handle, accepted."""
        handle = send_run_goal(self.action, target, relative=relative)
        assert handle.accepted
        return handle

    def run(self, target: float, relative: bool = False, timeout: float = 120.0):
        """The Run.Result of a goal (ValueError if rejected, WaitTimeout if no result in timeout s)."""
        return run_to(self.action, target, relative=relative, timeout=timeout)

    def reached(self, step: int) -> bool:
        """Whether the last state received so far is the one of step (none received: False)."""
        return bool(self.states) and self.states[-1].step == step

    def set(self, **values):
        changes = [Parameter(k, value=v) for k, v in values.items()]
        return answer_of(lambda: self.params.set_parameters(changes), 'set_parameters').results

    def get(self, name: str):
        from rclpy.parameter import parameter_value_to_python
        values = answer_of(lambda: self.params.get_parameters([name]), 'get_parameters').values
        return parameter_value_to_python(values[0])


def _start_graph(start_node, plant_overrides=None):
    responder = start_node('drive_testing', 'fixed_responder',
                           parameters={'switch_on': [float(s) for s in PATTERN]})
    plant = start_node('bldc_plant_sim', 'plant', parameters={**PLANT, **(plant_overrides or {})})
    return responder, plant


def test_ros_graph_equals_headless_loop_sample_for_sample(start_node, ros_session):
    _start_graph(start_node)
    client = PlantClient(ros_session)
    result = client.run(0.01)
    assert result.success, result.message
    assert result.final_step == 400 and result.final_time == pytest.approx(0.01, abs=1e-12)
    wait_until(lambda: client.reached(400), 10.0, what='last state')

    plant = PlantCore(PLANT)
    cosim = CoSimulation(plant, FixedGateCore(PATTERN), record_every=1)
    trajectory = cosim.run(steps=400)
    by_step = {s.step: s for s in client.states}
    assert set(range(1, 401)) <= set(by_step), 'a ground-truth sample is missing'
    compared = 0
    for step, truth in zip(trajectory.steps, trajectory.states):
        if step not in by_step:
            continue   # step 0 is published before the test subscribed
        ros = by_step[step]
        for name in ('phase_current', 'back_emf', 'terminal_voltage'):
            assert list(getattr(ros, name)) == list(getattr(truth, name)), (step, name)
        for name in ('electromagnetic_torque', 'mechanical_speed', 'rotor_angle',
                     'energy_dc_source', 'energy_copper_loss', 'neutral_voltage'):
            assert getattr(ros, name) == getattr(truth, name), (step, name)
        compared += 1
    assert compared >= 400
    # The run did something physical: V_ab drove current from phase a to b.
    last = by_step[400]
    assert last.phase_current[0] > 1.0 and last.phase_current[1] < -1.0


def test_blocks_carry_every_sample_bit_exact_across_holds(start_node, ros_session):
    # 7 samples per block: neither hold (step 124, step 164) ends a full block.
    _start_graph(start_node, {'telemetry.block_size': 7, 'telemetry.live_period': 250e-6})
    client = PlantClient(ros_session)
    assert client.run(0.0031).success                       # hold at step 124
    wait_until(lambda: client.reached(124), 10.0,
               what='the partial block flushed at the hold')
    assert client.blocks[-1].count == 125 % 7                # 17 full blocks + the partial one
    assert client.run(0.001, relative=True).success          # hold at step 164
    wait_until(lambda: client.reached(164), 30.0, what='the second partial block')

    # Every sample once, in order: none lost, none doubled by the hold.
    assert [s.step for s in client.states] == list(range(165))
    assert all(b.count <= 7 for b in client.blocks)
    trajectory = CoSimulation(PlantCore(PLANT), FixedGateCore(PATTERN), record_every=1).run(steps=164)
    truth = dict(zip(trajectory.steps, trajectory.states))
    for state in client.states:
        assert state.header.stamp.sec * 10**9 + state.header.stamp.nanosec == state.step * 25_000
        assert same_bits(state, truth[state.step]), state.step
    # The live topic: every 10th sample (250 us of sim time at 25 us), the same bits.
    wait_until(lambda: client.live and client.live[-1].step == 160, 10.0, what='live sample 160')
    assert [s.step for s in client.live] == list(range(0, 161, 10))
    for state in client.live:
        assert same_bits(state, truth[state.step]), state.step


def test_the_last_measurement_before_each_hold_is_marked(start_node, ros_session):
    """hold_after marks the controller's last due sample before each hold, whatever the
    period: with a DTC period of 3 ticks, holds at steps 124 and 164 mark 123 and 162."""
    from dtc_msgs.msg import DriveMeasurement
    _start_graph(start_node, {'dtc_period': 75e-6})
    client = PlantClient(ros_session)
    marks = {}
    seen = client.node.create_subscription(
        DriveMeasurement, topics.DRIVE_MEASUREMENT,
        lambda m: marks.__setitem__(m.step, m.hold_after), topics.LOCKSTEP_READER_QOS)
    wait_until(lambda: seen.get_publisher_count() >= 1, 30.0, what='drive/measurement matched')
    assert client.run(0.0031).success                          # hold at step 124
    assert client.run(0.001, relative=True).success            # hold at step 164
    wait_until(lambda: 162 in marks, 30.0, what='the measurement of step 162')
    assert sorted(marks) == list(range(0, 163, 3))
    assert sorted(step for step, held in marks.items() if held) == [123, 162]


def test_run_action_stops_exactly_and_holds(start_node, ros_session):
    _start_graph(start_node)
    client = PlantClient(ros_session)
    first = client.run(0.0031)
    assert first.success and first.final_step == 124          # 0.0031 / 25 us
    wait_until(lambda: client.reached(124), 10.0, what='state at the first hold')
    second = client.run(0.001, relative=True)
    assert second.success and second.final_step == 164
    wait_until(lambda: client.reached(164), 30.0, what='state at the target')
    time.sleep(0.5)
    assert client.states[-1].step == 164                       # held: nothing after the target


def test_controller_killed_mid_goal_gives_safe_state_and_plant_keeps_serving(start_node,
                                                                             ros_session):
    # The load machine holds 20 rad/s: line back-EMF 4.6 V peak < V_dc, so with every
    # switch off the diodes stop conducting once the currents have died out.
    # startup_timeout bounds the controller-less second goal below; 10 s leaves a loaded machine
    # time to match the responder for the first one.
    responder, _ = _start_graph(start_node, {'command_timeout': 4.0, 'startup_timeout': 10.0,
                                             'load.mode': 'dynamometer', 'load.speed': 20.0})
    client = PlantClient(ros_session)
    handle = client.start(0.2)
    wait_until(lambda: client.states and client.states[-1].step > 100, 30.0, what='run under way')
    assert client.states[-1].phase_current[0] > 1.0
    responder.process.kill()                       # in the middle of the goal
    responder.process.wait(timeout=10)
    started = time.monotonic()
    result = _future_result(handle.get_result_async(), 120.0, 'Run result').result
    assert not result.success and 'safe state' in result.message
    assert result.final_step == 8000               # went on to the target, switches off
    assert time.monotonic() - started < 100.0, 'plant hung instead of timing out'
    wait_until(lambda: client.reached(8000), 30.0, what='last state')
    state = client.states[-1]
    assert state.safe_state and state.protection & PlantState.PROTECTION_COMMAND_TIMEOUT
    assert not any(state.applied_switch_on)
    # With every switch off the currents died out through the free-wheeling diodes.
    assert list(state.phase_current) == [0.0, 0.0, 0.0]
    # Still serving: parameters and the action answer (without its controller the next
    # goal ends unsuccessful, in safe state, within a bounded time).
    assert client.set(**{'load.torque': 0.3})[0].successful
    assert client.get('load.torque') == 0.3
    started = time.monotonic()
    again = client.run(0.001, relative=True)
    assert not again.success and time.monotonic() - started < 30.0


def test_gate_command_for_the_wrong_inverter_is_refused_with_safe_state(start_node, ros_session):
    start_node('drive_testing', 'fixed_responder',
               parameters={'switch_on': [1.0, 0.0, 0.0, 1.0, 0.0, 0.0], 'topology': 4})
    start_node('bldc_plant_sim', 'plant', parameters=PLANT)
    client = PlantClient(ros_session)
    result = client.run(0.002)
    assert not result.success and '4-switch inverter' in result.message
    assert result.message.count('safe state at') == 1          # reported once, not every sample
    wait_until(lambda: client.reached(80), 30.0, what='last state')
    assert client.states[-1].safe_state and not any(client.states[-1].applied_switch_on)


def test_computation_delay_through_ros_equals_headless(start_node, ros_session):
    _start_graph(start_node, {'computation_delay': True})
    client = PlantClient(ros_session)
    assert client.run(0.002).success
    wait_until(lambda: client.reached(80), 30.0, what='last state')
    plant = PlantCore({**PLANT, 'computation_delay': True})
    trajectory = CoSimulation(plant, FixedGateCore(PATTERN), record_every=1).run(steps=80)
    by_step = {s.step: s for s in client.states}
    for step, truth in zip(trajectory.steps, trajectory.states):
        assert list(by_step[step].phase_current) == list(truth.phase_current), step
    # The delay shows: nothing was applied over the first sample.
    assert not any(by_step[1].applied_switch_on) and any(by_step[2].applied_switch_on)


def test_bad_parameters_are_rejected_with_a_reason_and_old_values_kept(start_node, ros_session):
    _start_graph(start_node)
    client = PlantClient(ros_session)
    before = client.get('load.torque')
    result = client.set(**{'load.torque': float('nan')})[0]
    assert not result.successful and 'load.torque' in result.reason
    assert client.get('load.torque') == before
    result = client.set(**{'inverter.topology': 5})[0]
    assert not result.successful and 'inverter.topology' in result.reason
    assert client.get('inverter.topology') == 6
    assert math.isclose(client.get('dc_link.voltage'), 10.0)
    for size in (0, -3, 10_001):                      # block sizes outside 1..10000
        result = client.set(**{'telemetry.block_size': size})[0]
        assert not result.successful and 'telemetry.block_size' in result.reason, result.reason
    assert client.get('telemetry.block_size') == DEFAULT_BLOCK_SIZE


def test_motor_and_topology_change_only_while_held(start_node, ros_session):
    _start_graph(start_node)
    client = PlantClient(ros_session)
    handle = client.start(0.05)
    wait_until(lambda: client.states and client.states[-1].step > 20, 30.0, what='run under way')
    refused = client.set(**{'motor.resistance': 0.5})[0]
    assert not refused.successful and 'held' in refused.reason, refused.reason
    assert client.set(**{'load.torque': 0.25})[0].successful         # runtime: accepted
    result = _future_result(handle.get_result_async(), 120.0, 'Run result').result
    assert result.success
    assert client.get('motor.resistance') == pytest.approx(0.315)
    # Held now: the same change is accepted and acts from the next sample on.
    assert client.set(**{'motor.resistance': 0.5})[0].successful
    assert client.get('motor.resistance') == 0.5
    assert client.run(0.001, relative=True).success


def test_peak_current_trip_latches_until_the_reset_service(start_node, ros_session):
    from dtc_msgs.srv import ResetProtection
    _start_graph(start_node, {'dc_link.voltage': 56.0, 'motor.initial_speed': 0.0})
    client = PlantClient(ros_session)
    result = client.run(0.004)                 # reached, but a tripped run is not a good one
    assert not result.success and result.final_step == 160 and result.fault_count == 1
    assert result.end_state.startswith('ended in fault state motor_over_current'), result.end_state
    wait_until(lambda: client.reached(160), 30.0, what='last state')
    tripped = client.states[-1]
    assert tripped.protection & PlantState.PROTECTION_MOTOR_OVER_CURRENT
    assert not any(tripped.applied_switch_on)
    peak = max(max(abs(i) for i in s.phase_current) for s in client.states)
    assert 23.0 < peak <= 24.0 + 1e-6          # trip located inside the sample, at 24 A
    reset = ros_session.node('reset_client').create_client(ResetProtection,
                                                           topics.RESET_PROTECTION_SERVICE)
    assert reset.wait_for_service(timeout_sec=30.0)
    answer = _future_result(reset.call_async(ResetProtection.Request()), 30.0, 'reset')
    assert answer.success, answer.message
    # The reset's sample goes out on the live topic only (a block would repeat step 160).
    wait_until(lambda: client.live and client.live[-1].step == 160 and
               not client.live[-1].protection & PlantState.PROTECTION_MOTOR_OVER_CURRENT,
               10.0, what='trip cleared in plant/state')
    assert [s.step for s in client.states] == list(range(161))
    assert client.live[-1].fault_count == 1    # the fault record stays latched after the reset


def test_motor_file_values_are_the_declared_parameters(start_node, ros_session):
    """What `ros2 param get` shows is what the plant uses: the file's values, explicit overrides
    on top, and a later motor.file change brings the new file's values with it."""
    start_node('drive_testing', 'fixed_responder')
    start_node('bldc_plant_sim', 'plant', parameters={'motor.file': 'fstp_pm_blac',
                                                      'motor.inertia': 1e-3})
    client = PlantClient(ros_session)
    assert client.get('motor.resistance') == pytest.approx(0.466)        # from the file
    assert client.get('motor.pole_pairs') == 1
    assert client.get('motor.inertia') == 1e-3                            # explicit override
    assert client.set(**{'motor.resistance': 2.0})[0].successful
    assert client.get('motor.resistance') == 2.0
    assert client.set(**{'motor.file': 'ozturk_bldc_nonideal'})[0].successful
    assert client.get('motor.resistance') == pytest.approx(0.315)
    assert client.get('motor.pole_pairs') == 2
    assert list(client.get('motor.backemf.harmonic_orders')) == [1.0, 3.0, 5.0]
    assert client.run(0.001).success


def test_run_until_says_the_run_ended_in_a_fault_state(start_node):
    # The hand-started run (run_until) of a plant that trips: the trip is logged when it
    # happens, and the end of the run is logged at ERROR with the end state, not as normal.
    start_node('drive_testing', 'fixed_responder', parameters={'switch_on': [float(s) for s in PATTERN]})
    plant = start_node('bldc_plant_sim', 'plant', parameters={
        **PLANT, 'dc_link.voltage': 56.0, 'motor.initial_speed': 0.0, 'run_until': 0.004})
    wait_until(lambda: 'run_until finished' in plant.output(), 120.0, what='the end of run_until')
    lines = plant.output().splitlines()
    trip = next(i for i, ln in enumerate(lines) if 'fault motor_over_current at t = ' in ln)
    end = next(i for i, ln in enumerate(lines) if 'run_until finished' in ln)
    assert trip < end and '[ERROR]' in lines[trip] and '[ERROR]' in lines[end]
    assert 'reached t = 0.004000 s (step 160), ended in fault state motor_over_current (first fault ' \
           'at t = ' in lines[end], lines[end]
