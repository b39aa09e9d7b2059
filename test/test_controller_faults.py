"""A misbehaving controller is handled by the plant as the built-ins are.

An in-test responder answers the plant's measurements correctly for the
first samples, then misbehaves: NaN or out-of-range duty, a wrong step
(stale or future: never applied, so the command timeout applies). Each
time the plant ends in the safe state, says so once on /diagnostics naming
the commanding node and the problem, and the Run goal reports it.
"""
import math

import pytest
from diagnostic_msgs.msg import DiagnosticArray

from drive_common import topics
from drive_common.waiting import wait_until
from dtc_msgs.msg import DriveMeasurement, DutyCommand, GateCommand, PfcMeasurement, PlantState

from test_plant_lockstep import PLANT, PlantClient

pytestmark = pytest.mark.ros

GOOD_SAMPLES = 20          # answered correctly first (readiness, then a normal run)
PFC_PLANT = {'motor.file': 'ozturk_bldc', 'dtc_period': 0.0, 'pfc_enabled': True,
             'pfc_period': 25e-6, 'front_end.enabled': True, 'dc_link.mode': 'current_fed',
             'dc_link.voltage': 80.0, 'command_timeout': 3.0}


class Responder:
    """Answers measurements on one lockstep channel; after GOOD_SAMPLES, mangle(command)."""

    def __init__(self, session, name, measurement, measurement_topic, command, command_topic,
                 fill, mangle) -> None:
        self.node = session.node(name)
        self.fill, self.mangle, self.command = fill, mangle, command
        self.pub = self.node.create_publisher(command, command_topic, topics.LOCKSTEP_QOS)
        self.node.create_subscription(measurement, measurement_topic, self.answer,
                                      topics.LOCKSTEP_QOS)

    def answer(self, msg) -> None:
        out = self.command(header=msg.header, step=msg.step)
        self.fill(out)
        if msg.step >= GOOD_SAMPLES:
            self.mangle(out)
        self.pub.publish(out)


def _diagnostics(session) -> list:
    seen = []
    session.node('diagnostics_probe').create_subscription(
        DiagnosticArray, topics.DIAGNOSTICS, lambda m: seen.extend(m.status), 10)
    return seen


def _duty(value):
    def set_duty(out):
        out.duty = value
    return set_duty


@pytest.mark.parametrize('bad_duty', [math.nan, 1.5])
def test_a_malformed_duty_gives_safe_state_with_a_diagnostic_naming_the_node(start_node, ros_session,
                                                                             bad_duty):
    seen = _diagnostics(ros_session)
    Responder(ros_session, 'bad_pfc', PfcMeasurement, topics.PFC_MEASUREMENT, DutyCommand, topics.DUTY_COMMAND,
              lambda out: setattr(out, 'duty', 0.3) or setattr(out, 'enable', True), _duty(bad_duty))
    start_node('bldc_plant_sim', 'plant', parameters=PFC_PLANT)
    client = PlantClient(ros_session)
    result = client.run(0.002)
    assert not result.success
    assert result.message.count('safe state at') == 1, result.message   # once, not every sample
    assert 'outside [0, 1]' in result.message and '/bad_pfc' in result.message
    wait_until(lambda: any('/bad_pfc' in s.message and 'duty' in s.message for s in seen), 10.0,
               what='a diagnostic naming /bad_pfc')
    wait_until(lambda: client.states and client.states[-1].step == 80, 10.0, what='last state')
    assert client.states[-1].safe_state


@pytest.mark.parametrize('offset', [-1, 1])
def test_a_command_for_the_wrong_step_is_not_applied_at_its_sample(start_node, ros_session, offset):
    # -1: stale answers are never applied, the plant stays safe to the end. +1: each answer
    # carries the next step, so the plant applies it at that step (one sample late) and resumes.
    seen = _diagnostics(ros_session)

    def wrong_step(out):
        out.step += offset

    Responder(ros_session, 'bad_dtc', DriveMeasurement, topics.DRIVE_MEASUREMENT, GateCommand,
              topics.GATE_COMMAND,
              lambda out: setattr(out, 'topology', 6) or setattr(
                  out, 'switch_on', [True, False, False, True, False, False]), wrong_step)
    start_node('bldc_plant_sim', 'plant', parameters={**PLANT, 'command_timeout': 2.0})
    client = PlantClient(ros_session)
    result = client.run(0.002)
    assert not result.success and result.message.count('safe state at') == 1, result.message
    assert f'no gate command for step {GOOD_SAMPLES}' in result.message
    assert '/bad_dtc' in result.message
    wait_until(lambda: any('/bad_dtc' in s.message for s in seen), 10.0,
               what='a diagnostic naming /bad_dtc')
    wait_until(lambda: client.states and client.states[-1].step == 80, 10.0, what='last state')
    last = client.states[-1]
    assert last.safe_state == (offset < 0)
    if offset < 0:
        assert not any(last.applied_switch_on)
    else:
        assert any('resumed' in s.message for s in seen)


def test_a_flapping_controller_is_reported_at_most_once_per_report_period(start_node, ros_session):
    # Every odd step's duty is NaN. The responder publishes each command one sample ahead (on
    # measurement k the command for k + 1); the plant waits for a controller that answers, even
    # wrongly, so it finds the next valid one and resumes: refused, resumed, refused, ...
    # /diagnostics and the goal's result carry one report per REPEAT_PERIOD = 0.1 s sim
    # (bldc_plant_sim.faults_reporting); the record counts every one.
    seen = _diagnostics(ros_session)
    node = ros_session.node('flapping_pfc')
    pub = node.create_publisher(DutyCommand, topics.DUTY_COMMAND, topics.LOCKSTEP_QOS)

    def answer(msg):
        for step in ([0, 1] if msg.step == 0 else [msg.step + 1]):
            bad = step >= GOOD_SAMPLES and step % 2
            pub.publish(DutyCommand(header=msg.header, step=step, duty=math.nan if bad else 0.3,
                                    enable=True))

    node.create_subscription(PfcMeasurement, topics.PFC_MEASUREMENT, answer, topics.LOCKSTEP_QOS)
    start_node('bldc_plant_sim', 'plant', parameters=PFC_PLANT)
    client = PlantClient(ros_session)
    result = client.run(0.002)                  # 80 samples: 30 malformed, all within 10 ms
    assert not result.success and result.message.count('safe state at') == 1, result.message
    wait_until(lambda: client.states and client.states[-1].step == 80, 10.0, what='last state')
    wait_until(lambda: any('resumed' in s.message for s in seen), 10.0, what='resumed')
    faults = [s.message for s in seen if 'flapping_pfc' in s.message]
    assert len(faults) == 1 and faults[0].startswith('invalid_command: duty command'), faults
    assert result.fault_count == 30 and list(result.fault_kinds) == ['invalid_command']
    assert client.states[-1].fault_counts[PlantState.FAULT_INVALID_COMMAND] == 30
    # 'resumed' follows the reported fault only, not the unreported ones after it.
    assert sum('resumed' in s.message for s in seen) == 1, [s.message for s in seen]
    assert client.states[-1].safe_state         # the last command (step 79) was NaN


class _SevenSwitchCore:
    """A user core with a bug: from GOOD_SAMPLES on it returns 7 switch states."""

    from drive_common.controller_api import schema as _schema
    SCHEMA = _schema([])

    def __init__(self, params) -> None:
        pass

    def reconfigure(self, params) -> None:
        pass

    def update(self, sample):
        from drive_common.controller_api import GateSample
        switches = (True, False, False, True, False, False) + ((True,) if sample.step >= GOOD_SAMPLES else ())
        return GateSample(sample.step, 6, switches), None


def test_a_command_of_the_wrong_length_is_not_sent():
    from drive_common.controller_api import CheckedCore, MalformedCommand
    from drive_common.samples import DriveSample
    reports = []
    core = CheckedCore(_SevenSwitchCore({}), reports.append)
    sample = DriveSample(GOOD_SAMPLES - 1, 0.0, (0.0,) * 3, 0.0, 0.0, 0, 0.0, 0, 0.0)
    assert len(core.update(sample)[0].switch_on) == 6
    sample.step = GOOD_SAMPLES
    with pytest.raises(MalformedCommand, match='6 bools'):
        core.update(sample)
    assert reports and 'not sent' in reports[0]


@pytest.mark.filterwarnings('ignore::pytest.PytestUnhandledThreadExceptionWarning')  # its thread ends
def test_a_controller_node_with_a_wrong_length_command_leaves_the_plant_safe(start_node, ros_session):
    # Serialization would truncate a 7-entry switch_on to bool[6] silently; the controller API
    # sends nothing instead, so the plant times out on it and names it.
    from drive_common.controller_api import controller_node
    seen = _diagnostics(ros_session)
    ros_session.add(controller_node(_SevenSwitchCore, 'seven_switches', status=False,
                                    context=ros_session.context))
    start_node('bldc_plant_sim', 'plant', parameters={**PLANT, 'command_timeout': 2.0})
    client = PlantClient(ros_session)
    result = client.run(0.002)
    assert not result.success and f'no gate command for step {GOOD_SAMPLES}' in result.message
    assert '/seven_switches' in result.message
    wait_until(lambda: any('/seven_switches' in s.message for s in seen), 10.0,
               what='a diagnostic naming /seven_switches')
    wait_until(lambda: client.states and client.states[-1].step == 80, 10.0, what='last state')
    assert client.states[-1].safe_state and not any(client.states[-1].applied_switch_on)


RAISING_CONTROLLER = '''
import sys
from drive_common.controller_api import GateSample, run_controller, schema


class RaisingCore:
    SCHEMA = schema([])

    def __init__(self, params):
        pass

    def reconfigure(self, params):
        pass

    def update(self, sample):
        if sample.step >= 20:
            raise RuntimeError(f'core bug at step {sample.step}')
        return GateSample(sample.step, 6, (True, False, False, True, False, False)), None


sys.exit(run_controller(RaisingCore, 'raising_controller'))
'''


def test_a_controller_whose_core_raises_exits_1_with_its_traceback_and_the_plant_goes_safe(
        start_node, ros_session, tmp_path):
    """A bug in a core is not survived as a node that is listed but never answers: the process
    prints the traceback and exits 1 (as an rclpy node whose callback raises), and the plant,
    after its command timeout, applies the safe state naming the node."""
    import sys
    script = tmp_path / 'raising_controller.py'
    script.write_text(RAISING_CONTROLLER)
    controller = start_node('drive_examples', 'raising_controller', argv=[sys.executable, str(script)])
    start_node('bldc_plant_sim', 'plant', parameters={**PLANT, 'command_timeout': 2.0})
    client = PlantClient(ros_session)
    result = client.run(0.002)
    assert not result.success and f'no gate command for step {GOOD_SAMPLES}' in result.message, result.message
    assert '/raising_controller' in result.message
    wait_until(lambda: not controller.alive(), 30.0, what='the controller process to exit')
    assert controller.process.returncode == 1
    out = controller.output()
    assert 'Traceback' in out and f'RuntimeError: core bug at step {GOOD_SAMPLES}' in out
    assert out.strip().splitlines()[-1] == (
        f'[raising_controller.py] error: RuntimeError: core bug at step {GOOD_SAMPLES} (traceback above)')
    wait_until(lambda: client.states and client.states[-1].step == 80, 10.0, what='last state')
    assert client.states[-1].safe_state and not any(client.states[-1].applied_switch_on)


# --- every fault is loud: log line, /diagnostics ERROR and PlantState fields at its sim time ----
def _fault_statuses(seen, kind: str) -> list:
    return [s for s in seen if s.name == 'plant: faults' and {v.key: v.value for v in s.values}.get('kind') == kind]


def test_a_trip_caused_by_a_runtime_parameter_change_is_reported_when_it_happens(start_node, ros_session):
    seen = _diagnostics(ros_session)
    start_node('drive_testing', 'fixed_responder',
               parameters={'switch_on': [1.0, 0.0, 0.0, 1.0, 0.0, 0.0]})
    plant = start_node('bldc_plant_sim', 'plant', parameters=PLANT)
    client = PlantClient(ros_session)
    first = client.run(0.002)
    assert first.success and first.end_state == 'ended normally' and first.fault_count == 0
    assert math.isnan(first.first_fault_time) and first.first_fault == ''
    wait_until(lambda: client.states and client.states[-1].step == 80, 10.0, what='state at the hold')
    current = max(abs(i) for i in client.states[-1].phase_current)
    assert current > 1.0
    assert client.set(**{'protection.peak_current': current / 2})[0].successful
    result = client.run(0.004)
    assert not result.success and result.fault_count == 1 and result.first_fault == 'motor_over_current'
    assert list(result.fault_kinds) == ['motor_over_current']
    t_trip = result.first_fault_time
    assert 0.002 <= t_trip <= 0.002 + 25e-6          # at the first tick after the change
    assert result.end_state.startswith(f'ended in fault state motor_over_current (first fault at t = '
                                       f'{t_trip:.6f} s: motor peak-current trip'), result.end_state
    assert 'ended in fault state motor_over_current' in result.message
    # /diagnostics: ERROR with the trip's sim time, step, kind, node and phase
    wait_until(lambda: _fault_statuses(seen, 'motor_over_current'), 10.0, what='the trip diagnostic')
    [status] = _fault_statuses(seen, 'motor_over_current')
    values = {v.key: v.value for v in status.values}
    assert status.level == status.ERROR and float(values['sim_time']) == pytest.approx(t_trip, abs=1e-9)
    assert values['step'] == '80' and values['node'] == '/plant' and values['phase'] in 'abc'
    # PlantState fields: no fault before the trip's step, latched from the next sample on
    wait_until(lambda: client.states and client.states[-1].step == 160, 10.0, what='last state')
    by_step = {s.step: s for s in client.states}
    assert by_step[80].fault_count == 0 and math.isnan(by_step[80].first_fault_time)
    after = by_step[81]
    assert after.fault_count == 1 and after.first_fault_kind == PlantState.FAULT_MOTOR_OVER_CURRENT
    assert after.fault_counts[PlantState.FAULT_MOTOR_OVER_CURRENT] == 1
    assert after.first_fault_time == t_trip and after.safe_state and after.protection & 1
    # the log line names the cause, the sim time and the node
    wait_until(lambda: f'fault motor_over_current at t = {t_trip:.6f} s' in plant.output(), 10.0,
               what='the trip log line')
    line = next(ln for ln in plant.output().splitlines() if 'fault motor_over_current at' in ln)
    assert 'ERROR' in line and 'node /plant' in line and 'peak-current trip' in line


@pytest.mark.parametrize('policy', ['safe_state', 'interlock'])
def test_a_shoot_through_controller_is_reported_naming_the_node_and_the_legs(start_node, ros_session,
                                                                           policy):
    seen = _diagnostics(ros_session)
    # leg a both on (shoot-through), leg b lower on
    start_node('drive_testing', 'fixed_responder', parameters={'switch_on': [1.0, 1.0, 0.0, 1.0, 0.0, 0.0]})
    plant = start_node('bldc_plant_sim', 'plant', parameters={**PLANT, 'inverter.shoot_through': policy})
    client = PlantClient(ros_session)
    result = client.run(0.001)
    assert not result.success and result.first_fault == 'shoot_through' and result.first_fault_time == 0.0
    assert result.end_state.startswith('ended in fault state shoot_through (first fault at t = 0.000000 s: '
                                       'shoot-through requested on leg a'), result.end_state
    wait_until(lambda: _fault_statuses(seen, 'shoot_through'), 10.0, what='a shoot-through diagnostic')
    values = {v.key: v.value for v in _fault_statuses(seen, 'shoot_through')[0].values}
    assert values['node'] == '/fixed_responder' and values['leg'] == 'a' and values['step'] == '0'
    assert values['policy'] == policy
    wait_until(lambda: client.states and client.states[-1].step == 40, 10.0, what='last state')
    last = client.states[-1]
    assert last.fault_counts[PlantState.FAULT_SHOOT_THROUGH] == result.fault_count >= 1
    if policy == 'safe_state':
        assert last.safe_state and last.protection & PlantState.PROTECTION_SHOOT_THROUGH
        assert not any(last.applied_switch_on)
    else:
        assert not last.safe_state and list(last.applied_switch_on) == [False, False, False, True,
                                                                        False, False]
    assert 'fault shoot_through at t = 0.000000 s (step 0), node /fixed_responder' in plant.output()


def test_an_undecodable_command_is_a_malformed_command_fault(start_node, ros_session):
    from rclpy.serialization import serialize_message
    seen = _diagnostics(ros_session)
    node = ros_session.node('garbling_dtc')
    pub = node.create_publisher(GateCommand, topics.GATE_COMMAND, topics.LOCKSTEP_QOS)

    def answer(msg):
        out = GateCommand(header=msg.header, step=msg.step, topology=6,
                          switch_on=[True, False, False, True, False, False])
        data = serialize_message(out)
        pub.publish(data if msg.step < GOOD_SAMPLES else data[:9])   # cut inside the header

    node.create_subscription(DriveMeasurement, topics.DRIVE_MEASUREMENT, answer, topics.LOCKSTEP_QOS)
    # The in-test responder answers from this process's executor: a command_timeout of 1 s was
    # missed once under CI load before the garbling began (step 7), so it has the default's room.
    start_node('bldc_plant_sim', 'plant', parameters={**PLANT, 'command_timeout': 5.0})
    client = PlantClient(ros_session)
    result = client.run(0.001)
    assert not result.success and 'malformed_command' in result.fault_kinds, result
    assert result.first_fault == 'malformed_command'
    wait_until(lambda: _fault_statuses(seen, 'malformed_command'), 10.0, what='malformed diagnostic')
    values = {v.key: v.value for v in _fault_statuses(seen, 'malformed_command')[0].values}
    assert values['node'] == '/garbling_dtc' and values['step'] == str(GOOD_SAMPLES)


def test_a_leaving_nodes_placeholder_name_is_never_reported():
    # rmw lists a leaving node's endpoints under _NODE_NAMESPACE_UNKNOWN_/_NODE_NAME_UNKNOWN_
    # (seen after a run_controller node's clean exit): the last real name is kept.
    from types import SimpleNamespace
    from bldc_plant_sim.plant_node import PlantNode
    infos: list = []
    plant = SimpleNamespace(_last_sources={}, get_publishers_info_by_topic=lambda topic: infos)
    unknown = SimpleNamespace(node_name='_NODE_NAME_UNKNOWN_', node_namespace='_NODE_NAMESPACE_UNKNOWN_')
    infos[:] = [SimpleNamespace(node_name='my_controller', node_namespace='/')]
    assert PlantNode._sources(plant, 'gate') == '/my_controller'
    infos[:] = [unknown]
    assert PlantNode._sources(plant, 'gate') == '/my_controller (leaving)'
    infos[:] = []
    assert PlantNode._sources(plant, 'gate') == 'no publisher; last seen: /my_controller, gone'
    plant._last_sources.clear()
    infos[:] = [unknown]
    assert PlantNode._sources(plant, 'gate') == 'unknown node (leaving)'
    infos[:] = []
    assert PlantNode._sources(plant, 'gate') == 'no publisher'
