"""Property-based fuzzing of scenario files and node parameters (hypothesis).

A damaged scenario is refused with a ScenarioError naming the file; a bad
parameter value with a ParameterError naming the parameter; a core's own
check refuses with ParameterError or ValueError. Never another exception:
a node would die of it, or a runner would print a traceback.
"""
from __future__ import annotations

import math

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from drive_bringup.scenario import NODE_SCHEMAS, ScenarioError, load_scenario, node_schema, scenario_dir
from drive_common.parameters import ParameterError

FUZZ = settings(deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
SCENARIOS = sorted(scenario_dir().glob('*.yaml'))

junk = st.recursive(
    st.none() | st.booleans() | st.integers(-10 ** 12, 10 ** 12)
    | st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner,
                                                                  max_size=4),
    max_leaves=8)


def _paths(tree, prefix=()):
    """Every key path of a parsed YAML tree (mappings and lists)."""
    yield prefix
    items = tree.items() if isinstance(tree, dict) else enumerate(tree) if isinstance(tree, list) else ()
    for key, value in items:
        yield from _paths(value, prefix + (key,))


def _replace(tree, path, value):
    if not path:
        return value
    node = tree
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return tree


def _delete(tree, path):
    if path:
        node = tree
        for key in path[:-1]:
            node = node[key]
        del node[path[-1]]
    return tree


def _load_or_scenario_error(path):
    try:
        return load_scenario(path)
    except ScenarioError as exc:
        assert str(path) in str(exc)
        return None


@FUZZ
@given(data=st.data())
def test_a_mutated_shipped_scenario_loads_or_names_file_key_and_reason(tmp_path_factory, data):
    source = data.draw(st.sampled_from(SCENARIOS), label='scenario')
    tree = yaml.safe_load(source.read_text())
    for _ in range(data.draw(st.integers(1, 3), label='mutations')):
        paths = list(_paths(tree))
        path = data.draw(st.sampled_from(paths), label='path')
        action = data.draw(st.sampled_from(('replace', 'delete', 'add')), label='action')
        if action == 'replace':
            tree = _replace(tree, path, data.draw(junk, label='value'))
        elif action == 'delete':
            tree = _delete(tree, path)
        else:
            target = tree
            for key in path:
                target = target[key]
            if isinstance(target, dict):
                target[data.draw(st.text(min_size=1, max_size=10), label='key')] = data.draw(junk)
    path = tmp_path_factory.mktemp('fuzz') / 'scenario.yaml'
    path.write_text(yaml.safe_dump(tree, allow_unicode=True))
    _load_or_scenario_error(path)


@FUZZ
@given(text=st.text(max_size=300) | st.binary(max_size=300).map(
    lambda b: b.decode('latin-1')))
def test_random_text_as_a_scenario_is_refused_with_a_scenario_error(tmp_path_factory, text):
    path = tmp_path_factory.mktemp('fuzz') / 'scenario.yaml'
    path.write_text(text, encoding='utf-8', errors='surrogateescape')
    _load_or_scenario_error(path)


def _core_checks():
    """Each node's full check of a new snapshot (schema, then core), as the node does it, on
    the cores of shipped scenarios."""
    from bldc_plant_sim.core.plant import PlantCore
    from dtc_controller.core.controller import DtcCore
    from pfc_controller.core.average_current_control import PfcCore
    drive = load_scenario(scenario_dir() / 'two_phase_six_switch_torque_step.yaml').node_parameters
    pfc = load_scenario(scenario_dir() / 'pfc_no_load_fig_3_5.yaml').node_parameters
    return {'plant': PlantCore(drive['plant']).check_params,
            'dtc_controller': DtcCore(drive['dtc_controller']).check,
            'pfc_controller': PfcCore(pfc['pfc_controller']).check}


CHECKS = {}


def _valid_value(spec):
    """Values a ROS parameter of this type may carry, in and out of range."""
    kind = spec.value_type
    if kind is bool:
        return st.booleans()
    if kind is int:
        return st.integers(-10 ** 9, 10 ** 9) | st.sampled_from(
            [v for v in (spec.min_value, spec.max_value, spec.default) if v is not None]).map(int)
    if kind is float:
        edges = [v for v in (spec.min_value, spec.max_value, spec.default) if v is not None]
        return (st.floats(allow_nan=True, allow_infinity=True)
                | st.sampled_from(edges + [0.0, -0.0, 1e-300]))
    if kind is str:
        return st.sampled_from(list(spec.choices) or [spec.default]) | st.text(max_size=12)
    element = type(spec.default[0]) if spec.default else float
    items = st.floats(allow_nan=True, allow_infinity=True) if element is float else st.text(max_size=6)
    return st.lists(items, max_size=(spec.length or 3) + 1)


@pytest.mark.parametrize('node', sorted(NODE_SCHEMAS))
@FUZZ
@given(data=st.data())
def test_parameter_changes_are_taken_or_refused_with_a_reason(node, data):
    """Random changes (right or wrong type, in or out of range, any spec): the node's check
    returns a full valid snapshot or raises ParameterError / ValueError, never anything else."""
    schema = node_schema(node)
    if node not in CHECKS:
        CHECKS.update(_core_checks())
    names = data.draw(st.lists(st.sampled_from(schema.names()), min_size=1, max_size=3,
                               unique=True), label='names')
    changes = {}
    for name in names:
        spec = schema[name]
        wrong_type = junk.filter(lambda v: not isinstance(v, type(spec.default)))
        changes[name] = data.draw(_valid_value(spec) | wrong_type, label=name)
    try:
        snapshot = CHECKS[node](changes)
    except (ParameterError, ValueError, OSError) as exc:
        assert str(exc)
        return
    for name in schema.names():
        spec = schema[name]
        value = snapshot[name]
        if isinstance(value, float):
            assert math.isfinite(value), name
        if spec.choices:
            assert value in spec.choices, name
        if spec.min_value is not None and isinstance(value, (int, float)):
            assert value >= spec.min_value, name
        if spec.max_value is not None and isinstance(value, (int, float)):
            assert value <= spec.max_value, name


def test_the_fuzzed_trees_are_real_scenarios():
    """The mutation fuzz starts from every shipped scenario, each of which loads as shipped."""
    assert len(SCENARIOS) >= 20
    for path in SCENARIOS:
        assert load_scenario(path).name == yaml.safe_load(path.read_text())['name']
