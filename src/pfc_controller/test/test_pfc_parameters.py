"""PFC_SCHEMA: every parameter documented; bad values rejected with a reason."""
import pytest

from drive_common.parameters import ParameterError
from pfc_controller.parameters import PFC_SCHEMA


def test_defaults_are_the_seed_values():
    d = PFC_SCHEMA.defaults()
    assert (d['voltage_kp'], d['voltage_ki'], d['current_kp'], d['current_ki']) == (
        0.1736, 0.01388, 0.005, 0.03125)
    assert d['voltage_reference'] == 80.0 and d['sample_period'] == 12.5e-6
    assert d['input_voltage_max'] / d['input_voltage_min'] == pytest.approx(2.5, rel=1e-3)
    assert (d['over_current_limit'], d['over_voltage_limit']) == (8.0, 140.0)


def test_every_parameter_documented_and_runtime_split():
    for spec in PFC_SCHEMA.specs:
        assert spec.description
        if isinstance(spec.default, float):
            assert spec.min_value is not None and spec.max_value is not None, spec.name
    runtime = {s.name for s in PFC_SCHEMA.specs if s.runtime}
    assert {'enable', 'voltage_reference', 'voltage_kp', 'voltage_ki', 'current_kp',
            'current_ki'} <= runtime
    assert 'sample_period' not in runtime
    assert PFC_SCHEMA['voltage_reference'].unit == 'V' and PFC_SCHEMA['sample_period'].unit == 's'


@pytest.mark.parametrize('changes, reason', [
    ({'voltage_kp': -0.1}, 'voltage_kp: -0.1 is below the minimum'),
    ({'current_ki': 2.0}, 'current_ki: 2.0 is above the maximum'),
    ({'enable': 1}, 'expected a bool'),
    ({'voltage_reference': float('nan')}, 'must be finite'),
    ({'voltage_reference': 60.0}, 'cannot regulate below the input peak'),
    ({'voltage_reference': 145.0}, 'over_voltage_limit'),
    ({'input_voltage_min': 80.0}, 'must be below input_voltage_max'),
    ({'sample_period': 1e-3}, 'line period'),
])
def test_bad_values_rejected_with_reason(changes, reason):
    with pytest.raises(ParameterError, match=reason):
        PFC_SCHEMA.validate_changes(PFC_SCHEMA.defaults(), changes)


def test_sample_period_only_while_held():
    with pytest.raises(ParameterError, match='held'):
        PFC_SCHEMA.validate_changes(PFC_SCHEMA.defaults(), {'sample_period': 25e-6}, running=True)
    snap = PFC_SCHEMA.validate_changes(PFC_SCHEMA.defaults(), {'voltage_kp': 0.2}, running=True)
    assert snap['voltage_kp'] == 0.2
