"""Every node's parameters through the standard parameter services.

A recorded graph (plant, dtc_controller, pfc_controller, recorder, replay) is
started as ``ros2 run`` would; rclpy's ``AsyncParameterClient`` -- what
ros2cli's ``param`` verbs use -- lists, describes, gets and sets parameters
of each node, as ``ros2 param list|describe|get|set|dump|load`` would.
"""
from __future__ import annotations

import math
from pathlib import Path

import pytest
from rcl_interfaces.msg import ParameterType
from rclpy.action import ActionClient
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient
from rclpy.serialization import serialize_message

from bldc_plant_sim.parameters import PLANT_SCHEMA
from drive_bringup.scenario import find_scenario, load_scenario
from drive_common import topics
from drive_common.run_goal import run_to
from drive_common.waiting import wait_until
from drive_testing.harness import answer_of
from drive_logger import qos_yaml
from drive_logger.bag_writer import BagWriter
from drive_logger.message_definitions import type_definition
from drive_logger.recorder_node import RECORDER_SCHEMA
from drive_logger.replay_node import REPLAY_SCHEMA
from dtc_controller.parameters import DTC_SCHEMA
from dtc_msgs.action import Run
from dtc_msgs.msg import DriveMeasurement, DtcStatus, PlantState
from pfc_controller.parameters import PFC_SCHEMA

pytestmark = pytest.mark.ros

SCENARIO = 'two_phase_six_switch_torque_step'
PLANT_TABLE = str(Path(__file__).resolve().parents[1] / 'src/bldc_plant_sim/motors/ozturk_bldc_nonideal_backemf.csv')
SCHEMAS = {'plant': PLANT_SCHEMA, 'dtc_controller': DTC_SCHEMA, 'pfc_controller': PFC_SCHEMA,
           'recorder': RECORDER_SCHEMA, 'replay': REPLAY_SCHEMA}
def _answer(call, what: str):
    """The response of call() (a parameter-client request), asked again every 10 s for 30 s."""
    return answer_of(call, what, 30.0, 10.0)


@pytest.fixture
def graph(start_node, ros_session, tmp_path):
    """The recorded drive graph plus a replay node; {name: AsyncParameterClient}."""
    scenario = load_scenario(find_scenario(SCENARIO))
    bag = BagWriter(tmp_path / 'source')
    topic = bag.add_topic('/probe/measurement', type_definition('dtc_msgs/msg/DriveMeasurement'),
                          [qos_yaml.profile()])
    bag.write(topic, serialize_message(DriveMeasurement(step=0)), 1, 1)
    bag.close()
    start_node('drive_logger', 'recorder', parameters={'output': str(tmp_path / 'bag')})
    start_node('bldc_plant_sim', 'plant', parameters=dict(scenario.overrides['plant'], run_until=0.0))
    start_node('dtc_controller', 'dtc_controller', parameters=scenario.overrides['dtc_controller'])
    start_node('pfc_controller', 'pfc_controller')
    # waits for a subscriber nobody provides: stays up, serving its parameters
    start_node('drive_logger', 'replay', parameters={'bag': str(tmp_path / 'source'),
                                                     'wait_for_subscribers': 600.0})
    probe = ros_session.node('parameter_probe')
    clients = {name: AsyncParameterClient(probe, f'/{name}') for name in SCHEMAS}
    for name, client in clients.items():
        assert client.wait_for_services(timeout_sec=60.0), f'{name}: no parameter services'
    return probe, clients


def _values(client, names) -> dict:
    response = _answer(lambda: client.get_parameters(names), 'get_parameters')
    return {n: parameter_value_to_python(v) for n, v in zip(names, response.values)}


def _set(client, name, value):
    return _answer(lambda: client.set_parameters([Parameter(name, value=value)]), f'set {name}').results[0]


def _same(a, b) -> bool:
    return list(a) == list(b) if isinstance(a, (list, tuple)) or hasattr(a, 'typecode') else a == b


def test_every_node_lists_and_describes_its_parameters_promptly(graph):
    _, clients = graph
    for name, client in clients.items():
        listed = _answer(lambda: client.list_parameters(), f'{name} list').result.names
        schema = SCHEMAS[name]
        assert set(schema.names()) <= set(listed), name
        described = _answer(lambda: client.describe_parameters(listed), f'{name} describe').descriptors
        assert [d.name for d in described] == list(listed)
        for d in described:
            if d.name not in schema:
                continue
            spec = schema[d.name]
            assert d.type != ParameterType.PARAMETER_NOT_SET and d.description, d.name
            assert d.read_only == spec.read_only, d.name
            for choice in spec.choices:             # allowed values are in the constraints
                assert str(choice) in d.additional_constraints, d.name
    recorder = _answer(lambda: clients['recorder'].describe_parameters(['output']), 'describe').descriptors[0]
    assert recorder.read_only
    mode = _answer(lambda: clients['dtc_controller'].describe_parameters(['mode']), 'describe').descriptors[0]
    assert 'two_phase_four_switch' in mode.additional_constraints


def _candidate(spec, current):
    """A valid value different from current (None: the parameter has no obvious other value)."""
    if spec.choices:
        return next(c for c in spec.choices if c != current)
    kind = spec.value_type
    if kind is bool:
        return not current
    lo = -math.inf if spec.min_value is None else spec.min_value
    hi = math.inf if spec.max_value is None else spec.max_value
    if kind is int:
        return current + 1 if current + 1 <= hi else current - 1
    if kind is float:
        for value in (current * 1.05, current * 0.95, current + 0.01, current - 0.01):
            if value != current and lo <= value <= hi:
                return value
    if kind is list and spec.default and isinstance(spec.default[0], float):
        return [v * 1.01 if lo <= v * 1.01 <= hi and v else min(max(v + 0.01, lo), hi)
                for v in current]
    return None


def _same_file(path: str) -> str:
    """Another spelling of the same file: a valid new value for a path parameter."""
    head, _, tail = path.rpartition('/')
    return f'{head}/./{tail}'


# Parameters whose other valid values depend on the rest of the set:
# before -> (changes to make first, new value); None: no other valid value.
SPECIAL = {
    'plant': {
        'base_tick': lambda b: ({'integration.max_step': b['base_tick'] / 2},
                                b['base_tick'] / 2),
        'integration.max_step': lambda b: ({}, b['integration.max_step'] / 2),
        'dtc_period': lambda b: ({}, 2 * b['dtc_period']),
        'pfc_period': lambda b: ({}, b['base_tick']),
        'pfc_enabled': lambda b: ({'pfc_period': b['base_tick'], 'dc_link.mode': 'current_fed',
                                   'front_end.enabled': True}, True),
        'front_end.enabled': lambda b: ({'dc_link.mode': 'current_fed'}, True),
        'inverter.dead_time': lambda b: ({}, 1e-6),
        'motor.file': lambda b: ({}, 'ozturk_bldc'),
        'motor.backemf.shape': lambda b: ({}, 'trapezoid'),
        'motor.backemf.table_file': lambda b: ({}, _same_file(PLANT_TABLE)),
        'motor.backemf.harmonic_orders': lambda b: ({}, [1.0, 3.0, 7.0]),
    },
    'dtc_controller': {
        'mode': lambda b: ({}, 'two_phase_four_switch'),
        'backemf_table_path': lambda b: ({}, _same_file(b['backemf_table_path'])),
        'motor.pole_pairs': None,        # must equal the back-EMF table's pole pairs
    },
    'pfc_controller': {},
}


@pytest.mark.parametrize('node', ['plant', 'dtc_controller', 'pfc_controller'])
def test_each_runtime_parameter_changes_through_the_parameter_service(graph, node):
    _, clients = graph
    client, schema = clients[node], SCHEMAS[node]
    before = _values(client, schema.names())
    changed = []
    for spec in schema.specs:
        if spec.read_only:
            continue
        special = SPECIAL[node]
        if spec.name in special:
            if special[spec.name] is None:
                continue
            prepare, new = special[spec.name](before)
        else:
            prepare, new = {}, _candidate(spec, before[spec.name])
        assert new is not None, f'{node} {spec.name}: no candidate value'
        for name, value in prepare.items():
            assert _set(client, name, value).successful, f'{node} {name} := {value!r}'
        result = _set(client, spec.name, new)
        assert result.successful, f'{node} {spec.name} := {new!r}: {result.reason}'
        now = _values(client, [spec.name])[spec.name]
        assert _same(now, new) if not isinstance(new, float) else now == pytest.approx(new), spec.name
        for name in [spec.name, *reversed(list(prepare))]:
            restored = _set(client, name, before[name])
            assert restored.successful, f'{node} {name} restore: {restored.reason}'
        changed.append(spec.name)
    assert _values(client, schema.names()) == before
    assert len(changed) == len([s for s in schema.specs if not s.read_only
                                and SPECIAL[node].get(s.name, 1) is not None])


@pytest.mark.parametrize('node, name, bad', [
    ('plant', 'sensors.current_offset', [0.0, 500.0, 0.0]),   # one element out of range
    ('plant', 'sensors.current_gain_error', [0.1, 0.0]),       # wrong length
    ('plant', 'load.mode', 'spring'),                         # not a choice
    ('dtc_controller', 'torque_band', -1.0),
    ('pfc_controller', 'duty_max', 2.0),
    ('recorder', 'chunk_size', 4096),                          # read-only
])
def test_a_rejected_value_keeps_the_old_one_and_says_why(graph, node, name, bad):
    _, clients = graph
    before = _values(clients[node], [name])[name]
    result = _set(clients[node], name, bad)
    assert not result.successful and result.reason
    assert name in result.reason or 'read-only' in result.reason, result.reason
    assert _same(_values(clients[node], [name])[name], before)


def test_changes_act_at_the_next_sample(graph):
    """dtc torque_reference reaches dtc/status; the plant's DC-link voltage plant/state."""
    probe, clients = graph
    statuses, states = [], []
    probe.create_subscription(DtcStatus, topics.DTC_STATUS, statuses.append, topics.STREAM_QOS)
    probe.create_subscription(PlantState, topics.PLANT_STATE, states.append, topics.STREAM_QOS)
    action = ActionClient(probe, Run, topics.RUN_ACTION)
    wait_until(action.server_is_ready, 30.0, what='plant/run')
    wait_until(lambda: probe.count_publishers(topics.DTC_STATUS) >= 1
               and probe.count_publishers(topics.PLANT_STATE) >= 1, 30.0, what='publishers')
    assert _set(clients['dtc_controller'], 'torque_reference', 0.321).successful
    assert _set(clients['plant'], 'dc_link.voltage', 47.5).successful
    array = [0.01, -0.02, 0.0]
    assert _set(clients['plant'], 'sensors.current_offset', array).successful
    assert run_to(action, 0.001).success
    wait_until(lambda: statuses and states and states[-1].step >= 25, 30.0, what='samples')
    assert all(s.torque_reference == 0.321 for s in statuses)
    assert all(s.dc_link_voltage == pytest.approx(47.5, rel=0.05) for s in states[:3])
    assert _values(clients['plant'], ['sensors.current_offset'])['sensors.current_offset'] == array


def test_get_all_then_set_all_round_trips_every_node(graph):
    """``ros2 param dump`` then ``ros2 param load``: every value back unchanged."""
    _, clients = graph
    for name, client in clients.items():
        names = list(_answer(lambda: client.list_parameters(), 'list').result.names)
        dumped = _answer(lambda: client.get_parameters(names), 'get').values
        read_only = {d.name for d in _answer(lambda: client.describe_parameters(names), 'describe').descriptors
                     if d.read_only}
        writable = [Parameter.from_parameter_msg(_msg(n, v)) for n, v in zip(names, dumped)
                    if n not in read_only]
        results = _answer(lambda: client.set_parameters(writable), 'set').results
        refused = {p.name: r.reason for p, r in zip(writable, results) if not r.successful}
        assert refused == {}, f'{name}: {refused}'
        for n in read_only:               # a read-only parameter refuses even its own value
            result = _set(client, n, parameter_value_to_python(dumped[names.index(n)]))
            assert not result.successful and 'read-only' in result.reason
        again = _answer(lambda: client.get_parameters(names), 'get').values
        assert again == dumped, name


def _msg(name, value):
    from rcl_interfaces.msg import Parameter as ParameterMsg
    return ParameterMsg(name=name, value=value)
