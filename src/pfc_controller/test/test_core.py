"""PfcCore behaviour: protection, enable, runtime changes at the next sample, purity."""
import subprocess
import sys

import pytest

from drive_common.parameters import ParameterError
from drive_common.samples import PfcSample
from pfc_controller.core import PfcCore, PfcStatusSample


def sample(k, v_in=30.0, i_l=2.0, v_o=78.0):
    return PfcSample(k, k * 12.5e-6, v_in, i_l, v_o)


def test_status_fields_equal_the_message_fields():
    from pathlib import Path
    msg = Path(__file__).resolve().parents[2] / 'dtc_msgs' / 'msg' / 'PfcStatus.msg'
    names = [line.split()[1] for line in msg.read_text().splitlines()
             if line.strip() and not line.startswith('#') and line.split()[1] != 'header']
    assert names == list(PfcStatusSample.__dataclass_fields__)


@pytest.mark.parametrize('meas, flag', [({'i_l': 8.5}, 'over_current'), ({'v_o': 141.0}, 'over_voltage')])
def test_protection_flags_hold_duty_zero(meas, flag):
    core = PfcCore({})
    for k in range(50):
        duty, _ = core.update(sample(k))
    assert duty.duty > 0.0
    duty, status = core.update(sample(50, **meas))
    assert duty.duty == 0.0 and status.duty == 0.0 and getattr(status, flag)
    duty, status = core.update(sample(51))
    assert duty.duty > 0.0 and not status.over_current and not status.over_voltage


def test_disable_and_reenable():
    core = PfcCore({})
    core.update(sample(0))
    core.reconfigure({'enable': False})
    duty, status = core.update(sample(1))
    assert (duty.duty, duty.enable, status.enabled) == (0.0, False, False)
    core.reconfigure({'enable': True})
    duty, status = core.update(sample(2))
    assert duty.enable and status.enabled


def test_reference_and_gains_act_at_the_next_sample():
    core = PfcCore({'voltage_reference_ramp_rate': 0.0})
    _, st = core.update(sample(0))
    assert st.voltage_reference == 80.0
    core.reconfigure({'voltage_reference': 100.0, 'voltage_kp': 0.5})
    _, st = core.update(sample(1, v_o=90.0))
    assert st.voltage_reference == 100.0
    assert core.params['voltage_kp'] == 0.5


def test_soft_start_ramps_from_measured_voltage():
    core = PfcCore({'voltage_reference_ramp_rate': 400.0})
    _, st0 = core.update(sample(0, v_o=40.0))
    _, st1 = core.update(sample(1, v_o=40.0))
    assert st0.voltage_reference == pytest.approx(40.0 + 400 * 12.5e-6)
    assert st1.voltage_reference - st0.voltage_reference == pytest.approx(400 * 12.5e-6)


def test_reconfigure_rejects_bad_values_and_keeps_old():
    core = PfcCore({})
    with pytest.raises(ParameterError):
        core.reconfigure({'current_kp': -1.0})
    assert core.params['current_kp'] == 0.005
    with pytest.raises(ParameterError, match='unknown'):
        PfcCore({'no_such_parameter': 1.0})


def test_duty_within_limits_under_large_errors():
    core = PfcCore({'duty_max': 0.9})
    for k in range(2000):
        duty, st = core.update(sample(k, v_in=5.0, i_l=0.0, v_o=60.0))
        assert 0.0 <= duty.duty <= 0.9
    assert st.current_loop_saturated and duty.duty == 0.9


def test_core_modules_do_not_import_ros():
    code = ('import sys, pfc_controller.core, pfc_controller.core.controller;'
            'bad=[m for m in sys.modules if m.startswith("rclpy") or m.split(".")[0].endswith("_msgs")];'
            'print(bad); sys.exit(1 if bad else 0)')
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stdout + result.stderr


def test_check_validates_a_change_without_applying_it():
    core = PfcCore()
    before = core.params
    checked = core.check({'voltage_reference': 90.0})
    assert checked['voltage_reference'] == 90.0 and core.params == before
    with pytest.raises(ParameterError):
        core.check({'voltage_kp': -1.0})
    assert core.params == before


def test_check_validates_the_line_period_without_building_the_average(monkeypatch):
    import pfc_controller.core.average_current_control as acc
    core = PfcCore()
    built = []
    original = acc.LinePeriodAverage
    monkeypatch.setattr(acc, 'LinePeriodAverage', lambda *a: built.append(a) or original(*a))
    checked = core.check({'line_frequency': 50.0})
    assert checked['line_frequency'] == 50.0 and built == []
    with pytest.raises((ParameterError, ValueError)):
        core.check({'line_frequency': 50.0, 'sample_period': 0.015})   # not below the line period
    assert built == []
    core.reconfigure({'line_frequency': 50.0})
    assert built == [(50.0, core.params['sample_period'])]          # built once, when applied
