"""The plant node's parameter schema: units, ranges, runtime flags and refusals with a reason."""
from __future__ import annotations

from pathlib import Path

import pytest

from bldc_plant_sim.core import plant_kernel as PK
from bldc_plant_sim.core.plant import PlantCore
from bldc_plant_sim.parameters import PLANT_SCHEMA, effective_params, load_motor_file, plant_params
from drive_common.parameters import ParameterError


def test_every_parameter_is_described_and_runtime_flags_follow_the_issue():
    for spec in PLANT_SCHEMA.specs:
        assert spec.description
        if isinstance(spec.default, float) and spec.name not in ('dc_link.initial_midpoint',
                                                                  'sensors.voltage_gain_error'):
            assert spec.unit or spec.name.startswith('motor.backemf'), spec.name
    runtime = {s.name: s.runtime for s in PLANT_SCHEMA.specs}
    for name in ('load.mode', 'load.torque', 'load.speed', 'sensors.current_noise',
                 'sensors.current_offset', 'inverter.v_ce', 'inverter.v_d', 'inverter.r_on'):
        assert runtime[name], name
    for name in ('motor.resistance', 'motor.pole_pairs', 'motor.backemf.shape', 'inverter.topology',
                 'inverter.midpoint_phase', 'base_tick', 'dtc_period', 'dc_link.mode'):
        assert not runtime[name], name


@pytest.mark.parametrize('changes, reason', [
    ({'motor.resistance': -0.1}, 'below the minimum'),
    ({'inverter.topology': 5}, 'not one of'),
    ({'motor.mutual_inductance': 2e-3}, 'L - M must be positive'),
    ({'inverter.dead_time': 30e-6}, 'shorter than base_tick'),
    ({'dtc_period': 30e-6}, 'integer multiple'),
    ({'motor.backemf.harmonic_coefficients': [1.0, 0.1]}, 'harmonic_orders'),
    ({'motor.backemf.shape': 'table'}, 'table_file'),
    ({'sensors.current_offset': [0.0, 0.0]}, 'expected 3 values'),
    ({'load.mode': 'brake'}, 'not one of'),
    ({'no.such.parameter': 1.0}, 'unknown parameter'),
])
def test_schema_rejects_bad_values_with_a_reason(changes, reason):
    with pytest.raises(ParameterError, match=reason):
        plant_params(**changes)


def test_held_parameters_are_refused_while_running_and_runtime_ones_apply():
    snap = plant_params()
    with pytest.raises(ParameterError, match='held'):
        PLANT_SCHEMA.validate_changes(snap, {'motor.resistance': 0.5}, running=True)
    new = PLANT_SCHEMA.validate_changes(snap, {'load.torque': 0.5, 'inverter.v_d': 1.25}, running=True)
    plant = PlantCore(snap)
    plant.reconfigure(new)
    assert plant.load.torque == 0.5 and plant.inverter.v_d == 1.25


def test_unknown_motor_file_and_bad_table_file_are_refused():
    with pytest.raises(ParameterError, match='no motor file'):
        PlantCore({'motor.file': 'no_such_motor'})
    with pytest.raises(ValueError, match='/nonexistent.csv:0: cannot read back-EMF table'):
        PlantCore({'motor.backemf.shape': 'table', 'motor.backemf.table_file': '/nonexistent.csv'})


def test_motor_file_parameter_loads_the_file():
    plant = PlantCore({'motor.file': 'fstp_pm_blac'})
    assert plant.motor.pole_pairs == 1 and plant.params['motor.resistance'] == 0.466


# ---- motor.file semantics: the file gives the motor, explicit parameters override it ----------

def test_explicit_motor_parameters_override_the_motor_file_and_are_reported():
    plant = PlantCore({'motor.file': 'fstp_pm_blac', 'motor.resistance': 2.0, 'motor.friction': 0.002})
    assert plant.motor.resistance == 2.0 and plant.params['motor.resistance'] == 2.0
    assert plant.motor.friction == 0.002 and plant.params['motor.friction'] == 0.002
    assert plant._prm[PK.PR_R] == 2.0                               # the integration uses it
    # everything not set explicitly comes from the file
    assert plant.motor.pole_pairs == 1 and plant.params['motor.self_inductance'] == 3.19e-3
    assert plant.params['protection.peak_current'] == 10.0 and plant.trip.level == 10.0


def test_scenario_snapshot_with_motor_file_uses_the_scenario_values():
    # a scenario's plant block resolved through the schema (full snapshot, as the runner does)
    snap = PLANT_SCHEMA.resolve({'motor.file': 'ozturk_bldc', 'motor.inertia': 1e-3})
    plant = PlantCore(snap)
    assert plant.motor.inertia == 1e-3 and plant.params['motor.inertia'] == 1e-3
    assert plant.params['motor.backemf.constant'] == pytest.approx(0.0573)


def test_reconfigure_while_held_changes_the_resistance_used_by_the_core():
    # headless flow: the requested snapshot keeps the defaults, the core keeps the effective one
    requested = PLANT_SCHEMA.resolve({'motor.file': 'fstp_pm_blac'})
    plant = PlantCore(requested)
    assert plant.motor.resistance == 0.466
    requested = PLANT_SCHEMA.validate_changes(requested, {'motor.resistance': 2.0})
    plant.reconfigure(requested)
    assert plant.motor.resistance == 2.0 and plant._prm[PK.PR_R] == 2.0
    assert plant.params['motor.resistance'] == 2.0
    assert plant._prm[PK.PR_TAU] == pytest.approx(3.19e-3 / 2.0)
    # an unrelated change later keeps both the explicit value and the file's others
    plant.reconfigure(PLANT_SCHEMA.validate_changes(requested, {'load.torque': 0.1}))
    assert plant.motor.resistance == 2.0 and plant.motor.inductance == 3.19e-3
    # node flow: the node reports (writes back) plant.params and sends changes on top of it
    plant.reconfigure(PLANT_SCHEMA.validate_changes(plant.params, {'motor.resistance': 0.7}))
    assert plant.motor.resistance == 0.7 and plant.motor.pole_pairs == 1


def test_effective_params_recipe_for_the_node():
    # start-up: declared values (defaults + overrides) -> values used, written back by the node
    declared = PLANT_SCHEMA.resolve({'motor.file': 'fstp_pm_blac', 'motor.resistance': 2.0})
    used = effective_params(declared)
    assert used['motor.resistance'] == 2.0 and used['motor.self_inductance'] == 3.19e-3
    assert used['motor.pole_pairs'] == 1 and used['protection.peak_current'] == 10.0
    assert effective_params(used, used) == used                          # write-back is a fixed point
    # a start-up override equal to its default only counts as set when named in explicit
    declared = PLANT_SCHEMA.resolve({'motor.file': 'fstp_pm_blac', 'motor.resistance': 0.315})
    assert effective_params(declared)['motor.resistance'] == 0.466
    assert effective_params(declared, explicit={'motor.resistance'})['motor.resistance'] == 0.315
    # runtime change while held: `ros2 param set /plant motor.resistance 0.9` acts and reads back
    changed = PLANT_SCHEMA.validate_changes(used, {'motor.resistance': 0.9})
    assert effective_params(changed, used)['motor.resistance'] == 0.9
    # a new motor file replaces the file values, except names set in the same change
    swap = PLANT_SCHEMA.validate_changes(used, {'motor.file': 'ozturk_bldc', 'motor.inertia': 5e-4})
    new = effective_params(swap, used)
    assert new['motor.pole_pairs'] == 2 and new['motor.resistance'] == 0.315
    assert new['motor.inertia'] == 5e-4
    assert new['motor.backemf.shape'] == 'trapezoid'
    # names only the old file set go back to their defaults
    assert new['motor.backemf.harmonic_orders'] == PLANT_SCHEMA['motor.backemf.harmonic_orders'].default
    assert new['protection.peak_current'] == 24.0


# ---- motor files are checked by the schema, errors name the file, key and reason ------------

@pytest.mark.parametrize('key, value, reason', [
    ('motor.resistance', -1, 'below the minimum'),
    ('motor.inertia', 0, 'below the minimum'),
    ('motor.pole_pairs', 1.5, 'expected an integer'),
    ('motor.backemf.shape', 'square', 'not one of'),
    ('motor.backemf.phase_gain', [1.0, 1.0], 'expected 3 values'),
])
def test_motor_file_values_are_checked_by_the_schema(tmp_path, key, value, reason):
    path = tmp_path / 'bad_motor.yaml'
    path.write_text(f'parameters:\n  {key}: {value}\n'.replace("'", ''))
    for make in (lambda: PlantCore({'motor.file': str(path)}), lambda: plant_params(str(path))):
        with pytest.raises(ParameterError) as err:
            make()
        text = str(err.value)
        assert str(path) in text and key in text and reason in text, text


def test_motor_file_cross_check_failure_names_the_file(tmp_path):
    path = tmp_path / 'mutual.yaml'
    path.write_text('parameters:\n  motor.self_inductance: 1.0e-3\n  motor.mutual_inductance: 2.0e-3\n')
    with pytest.raises(ParameterError, match=r'L - M must be positive.*mutual\.yaml'):
        PlantCore({'motor.file': str(path)})


# ---- defaults: 001 Table IV device drops, the 000 App. A motor file ---------------------------

def test_device_drop_defaults_are_001_table_iv():
    d = PLANT_SCHEMA.defaults()
    assert (d['inverter.v_ce'], d['inverter.v_d'], d['inverter.r_on']) == (0.9, 1.25, 0.075)
    plant = PlantCore({})
    assert (plant.inverter.v_ce, plant.inverter.v_d, plant.inverter.r_on) == (0.9, 1.25, 0.075)


def test_motor_defaults_are_the_000_appendix_a_motor_file():
    d = PLANT_SCHEMA.defaults()
    for key, value in load_motor_file('ozturk_bldc').items():
        assert d[key] == pytest.approx(value), key


SCENARIOS = Path(__file__).resolve().parents[2] / 'drive_bringup' / 'scenarios'


@pytest.mark.skipif(not SCENARIOS.is_dir(), reason='drive_bringup scenarios not beside this package')
def test_shipped_scenarios_state_their_device_drops():
    import yaml
    names = sorted(SCENARIOS.glob('*.yaml'))
    assert names
    for path in names:
        plant = yaml.safe_load(path.read_text())['nodes']['plant']['parameters']
        drops = tuple(plant.get(k) for k in ('inverter.v_ce', 'inverter.v_d', 'inverter.r_on'))
        if str(plant.get('motor.file', '')).startswith('ozturk'):     # 000: devices neglected
            assert drops == (0.0, 0.0, 0.0), path.name
        else:                                                         # 001: Table IV
            assert drops == (0.9, 1.25, 0.075), path.name
