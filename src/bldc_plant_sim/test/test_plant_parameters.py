"""The plant node's parameter schema: units, ranges, runtime flags and refusals with a reason."""
from __future__ import annotations

import pytest

from bldc_plant_sim.core.plant import PlantCore
from bldc_plant_sim.parameters import PLANT_NODE_SCHEMA, plant_params
from drive_common.parameters import ParameterError


def test_every_parameter_is_described_and_runtime_flags_follow_the_issue():
    for spec in PLANT_NODE_SCHEMA.specs:
        assert spec.description
        if isinstance(spec.default, float) and spec.name not in ('dc_link.initial_midpoint',
                                                                  'sensors.voltage_gain_error'):
            assert spec.unit or spec.name.startswith('motor.backemf'), spec.name
    runtime = {s.name: s.runtime for s in PLANT_NODE_SCHEMA.specs}
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
        PLANT_NODE_SCHEMA.validate_changes(snap, {'motor.resistance': 0.5}, running=True)
    new = PLANT_NODE_SCHEMA.validate_changes(snap, {'load.torque': 0.5, 'inverter.v_d': 1.25}, running=True)
    plant = PlantCore(snap)
    plant.reconfigure(new)
    assert plant.load.torque == 0.5 and plant.inverter.v_d == 1.25


def test_unknown_motor_file_and_bad_table_file_are_refused():
    with pytest.raises(ParameterError, match='no motor file'):
        PlantCore({'motor.file': 'no_such_motor'})
    with pytest.raises(OSError):
        PlantCore({'motor.backemf.shape': 'table', 'motor.backemf.table_file': '/nonexistent.csv'})


def test_motor_file_parameter_loads_the_file():
    plant = PlantCore({'motor.file': 'fstp_pm_blac'})
    assert plant.motor.pole_pairs == 1 and plant.params['motor.resistance'] == 0.466
