"""DtcCore: API, status fields, reconfiguration, modes; plus a small closed loop against a
test-local BLDC model (constant speed, diode free-wheeling) -- no plant code involved."""
import math
import re
import subprocess
import sys
from dataclasses import fields
from pathlib import Path

import pytest

from drive_common.parameters import ParameterError
from drive_common.samples import DriveSample
from dtc_controller.core.controller import DtcCore, DtcStatusSample
from dtc_controller.core.vectors import HIGH, LOW, MIDPOINT, OPEN, leg_states
from dtc_controller.parameters import DTC_SCHEMA
from dtc_test_tables import make_table

MSG = Path(__file__).resolve().parents[2] / 'dtc_msgs' / 'msg' / 'DtcStatus.msg'
NAN = float('nan')


def sample(step=0, theta=0.2, i=(1.0, -0.5, -0.5), speed=10.0, vdc=56.57):
    return DriveSample(step, step * 25e-6, i, vdc, 0.5 * vdc, 0, theta, 0, speed)


def test_status_fields_equal_message_fields():
    names = []
    for line in MSG.read_text().splitlines():
        line = line.split('#')[0].strip()
        if line:
            names.append(re.split(r'\s+', line)[1])
    names.remove('header')
    assert [f.name for f in fields(DtcStatusSample)] == names


def test_core_imports_no_ros_and_no_plant():
    code = ('import sys, dtc_controller.core.controller, dtc_controller.parameters;'
            'bad=[m for m in sys.modules if m.startswith("rclpy") or m.split(".")[0].endswith("_msgs")'
            ' or m.startswith("bldc_plant_sim")]; print(bad); sys.exit(1 if bad else 0)')
    assert subprocess.run([sys.executable, '-c', code]).returncode == 0


def test_schema_runtime_flags():
    assert DTC_SCHEMA['mode'].runtime is False and 'held' in DTC_SCHEMA['mode'].describe()
    for name in ('torque_reference', 'torque_band', 'speed_reference', 'speed_loop.kp', 'speed_loop.ki',
                 'flux_band', 'four_switch.split_band_divisor', 'flux_control.enabled'):
        assert DTC_SCHEMA[name].runtime, name
    with pytest.raises(ParameterError):
        DTC_SCHEMA.validate_changes(DTC_SCHEMA.defaults(), {'mode': 'three_phase_pmsm'}, running=True)


def test_update_returns_gate_and_status(trap_table):
    core = DtcCore({'torque_reference': 1.0}, trap_table)
    gate, st = core.update(sample(step=7))
    assert gate.step == 7 and gate.topology == 6 and st.step == 7
    assert st.mode == 'two_phase_six_switch' and st.sector == 1 and st.torque_hysteresis == 1
    assert st.voltage_vector == 2 and gate.switch_on == (False, False, True, False, False, True)
    assert math.isnan(st.speed_reference) and math.isnan(st.flux_reference) and st.flux_hysteresis == 0
    assert math.isnan(st.phase_a_torque_estimate) and st.d_current_hysteresis == 0


def test_missing_current_sensor_reconstructed(trap_table):
    a = DtcCore({}, trap_table).update(sample(i=(2.0, NAN, -1.5)))[1]
    b = DtcCore({}, trap_table).update(sample(i=(2.0, -0.5, -1.5)))[1]
    assert a.torque_estimate == pytest.approx(b.torque_estimate) and a.d_current == pytest.approx(b.d_current)


def test_reconfigure_applies_at_next_sample(trap_table):
    core = DtcCore({'torque_reference': 5.0, 'torque_band': 0.01}, trap_table)
    assert core.update(sample())[1].torque_hysteresis == 1
    core.reconfigure({'torque_reference': -5.0})
    assert core.mode._prm[core.mode.kernel.P_TORQUE_REF] == 5.0  # not yet applied
    st = core.update(sample(step=1))[1]
    assert st.torque_reference == -5.0 and st.torque_hysteresis == -1
    core.reconfigure({'rotation': -1})
    st = core.update(sample(step=2))[1]
    assert st.rotation == -1 and st.torque_hysteresis == 1  # error taken in the commanded (CW) direction
    with pytest.raises(ParameterError):
        core.reconfigure({'torque_band': -1.0})


def test_mode_dispatch_and_errors(trap_table):
    four = DtcCore({'mode': 'two_phase_four_switch', 'torque_reference': 1.0}, trap_table)
    gate, st = four.update(sample(theta=math.radians(60)))
    assert gate.topology == 4 and gate.switch_on[4:] == (False, False)
    assert st.sector == 2 and not math.isnan(st.phase_a_torque_estimate)
    for mode, topology in (('three_phase_dtifc', 6), ('three_phase_pmsm', 6),
                           ('three_phase_four_switch', 4)):
        assert DtcCore({'mode': mode}, trap_table).topology == topology
    with pytest.raises(ValueError, match='back-EMF table'):
        DtcCore({}, None)
    with pytest.raises(ValueError, match='pole_pairs'):
        DtcCore({'motor.pole_pairs': 4}, trap_table)


def test_table_loaded_from_path(tmp_path, trap_table):
    p = tmp_path / 't.csv'
    trap_table.write(p)
    core = DtcCore({'backemf_table_path': str(p)}, None)
    assert core.backemf.points == 360


def test_speed_loop_sets_torque_reference(trap_table):
    core = DtcCore({'speed_loop.enabled': True, 'speed_reference': 30.0, 'speed_loop.kp': 0.01,
                    'speed_loop.ki': 0.0}, trap_table)
    st = core.update(sample(speed=10.0))[1]
    assert st.speed_reference == 30.0 and st.torque_reference == pytest.approx(0.2)


def test_flux_control_uses_phi_rows(trap_table):
    core = DtcCore({'flux_control.enabled': True, 'flux_control.reference_source': 'constant',
                    'flux_reference': 1.0, 'torque_reference': 1.0}, trap_table)
    st = core.update(sample())[1]
    assert st.flux_hysteresis == 1 and st.flux_reference == 1.0 and st.voltage_vector == 1  # Table II phi=1


# ----------------------------------------------------------------- closed loop, test-local motor
class ConstantSpeedBldc:
    """Y-connected BLDC at constant speed; legs with both switches off free-wheel through diodes
    until their current reaches zero, then the phase is open. Forward Euler with substeps."""

    def __init__(self, table, omega_e, v_dc, r=0.315, l=1.0875e-3, p=2, midpoint=None, theta0=0.3):
        self.t, self.w, self.v_dc, self.r, self.l, self.p = table, omega_e, v_dc, r, l, p
        self.mid = midpoint
        self.theta = theta0
        self.i = [0.0, 0.0, 0.0]

    def torque(self):
        k = self.t.k_abc(self.theta)
        return self.p * sum(kx * ix for kx, ix in zip(k, self.i))

    def run(self, switch_on, duration, n_sub=25):
        legs = leg_states(switch_on, self.mid)
        h = duration / n_sub
        for _ in range(n_sub):
            e = [self.w * k for k in self.t.k_abc(self.theta)]
            term = []
            for x in range(3):
                leg = legs[x]
                if leg == HIGH:
                    term.append(self.v_dc)
                elif leg == LOW:
                    term.append(0.0)
                elif leg == MIDPOINT:
                    term.append(0.5 * self.v_dc)
                elif abs(self.i[x]) > 1e-9:
                    term.append(0.0 if self.i[x] > 0 else self.v_dc)  # diode
                else:
                    term.append(None)
            cond = [x for x in range(3) if term[x] is not None]
            if len(cond) < 2:
                self.i = [0.0, 0.0, 0.0]
            else:
                v_n = (sum(term[x] - e[x] for x in cond)) / len(cond)
                new = list(self.i)
                for x in cond:
                    new[x] = self.i[x] + h * (term[x] - v_n - e[x] - self.r * self.i[x]) / self.l
                for x in cond:  # a free-wheeling current stops at zero
                    if legs[x] == OPEN and new[x] * self.i[x] < 0:
                        new[x] = 0.0
                s = sum(new[x] for x in cond)
                for x in cond:
                    new[x] -= s / len(cond)
                self.i = [new[x] if x in cond else 0.0 for x in range(3)]
            self.theta = (self.theta + self.w * h) % (2 * math.pi)


def run_loop(mode, t_ref, rotation, v_dc, band, n, midpoint=None):
    tab = make_table('trapezoid')
    omega_e = rotation * 60.0
    motor = ConstantSpeedBldc(tab, omega_e, v_dc, midpoint=midpoint)
    core = DtcCore({'mode': mode, 'torque_reference': t_ref, 'rotation': rotation, 'torque_band': band}, tab)
    est, true, ic = [], [], []
    for k in range(n):
        s = DriveSample(k, k * 25e-6, tuple(motor.i), v_dc, 0.5 * v_dc, 0, motor.theta, 0, omega_e / 2)
        gate, st = core.update(s)
        if k > n // 4:
            est.append(st.torque_estimate)
            true.append(motor.torque())
            ic.append((st.sector, motor.i[2]))
        motor.run(gate.switch_on, 25e-6)
    return est, true, ic


@pytest.mark.parametrize('rotation', [1, -1])
def test_closed_loop_six_switch_tracks_torque(rotation):
    t_ref = rotation * 1.0
    est, true, _ = run_loop('two_phase_six_switch', t_ref, rotation, 40 * math.sqrt(2), 0.001, 1400)
    mean = sum(true) / len(true)
    rms_err = math.sqrt(sum((a - b) ** 2 for a, b in zip(est, true)) / len(est))
    assert mean == pytest.approx(t_ref, abs=0.1)
    assert rms_err < 0.01  # estimator = model torque (same table) up to the sample delay


@pytest.mark.parametrize('rotation', [1, -1])
def test_closed_loop_four_switch_tracks_torque_and_keeps_ic_small(rotation):
    t_ref = rotation * 0.5
    est, true, ic = run_loop('two_phase_four_switch', t_ref, rotation, 80 * math.sqrt(2), 0.05, 1400, midpoint=2)
    mean = sum(true) / len(true)
    assert mean == pytest.approx(t_ref, abs=0.1)
    i_c_split = [abs(i) for sector, i in ic if sector in (2, 5)]
    # phase c held near zero while a and b conduct: it ripples about zero by one sample's
    # V_dc/3 step (0.87 A at 25 us, cf. 000 Fig. 4.13) instead of following its back-EMF
    signed = [i for sector, i in ic if sector in (2, 5)]
    assert len(signed) > 100
    assert abs(sum(signed) / len(signed)) < 0.1
    assert sum(i_c_split) / len(i_c_split) < 0.35  # vs. about 2.2 A in phases a and b


def test_check_validates_a_change_without_rebuilding_or_rereading_the_table(tmp_path, monkeypatch):
    from dtc_controller.core.backemf_table import BackEmfTable
    path = tmp_path / 'table.csv'
    make_table('trapezoid').write(path)
    core = DtcCore({'backemf_table_path': str(path)})
    mode, params = core.mode, dict(core.params)
    loads = []
    original = BackEmfTable.load
    monkeypatch.setattr(BackEmfTable, 'load', classmethod(lambda cls, *a, **k: loads.append(a) or original(*a, **k)))
    checked = core.check({'torque_reference': 0.5, 'mode': 'two_phase_four_switch'})
    assert checked['torque_reference'] == 0.5 and checked['mode'] == 'two_phase_four_switch'
    assert loads == []                                # same file and motor: the loaded table is reused
    assert core.mode is mode and core.params == params   # nothing applied
    with pytest.raises(ParameterError):
        core.check({'torque_band': -1.0})
    with pytest.raises(ValueError, match='needs a back-EMF table'):
        core.check({'backemf_table_path': ''})        # a two-phase mode without a table
    with pytest.raises(ValueError, match='pole_pairs'):
        core.check({'motor.pole_pairs': 3})           # the table is re-read for the new motor
    assert len(loads) == 1 and core.params == params


def test_a_table_read_by_check_is_the_one_the_reconfigure_builds_with(tmp_path, monkeypatch):
    from dtc_controller.core.backemf_table import BackEmfTable
    first, second = tmp_path / 'first.csv', tmp_path / 'second.csv'
    make_table('trapezoid').write(first)
    make_table('trapezoid').write(second)
    core = DtcCore({'backemf_table_path': str(first)})
    loads = []
    original = BackEmfTable.load
    monkeypatch.setattr(BackEmfTable, 'load', classmethod(lambda cls, *a, **k: loads.append(a) or original(*a, **k)))
    change = {'backemf_table_path': str(second)}
    core.check(change)                                # a node validates the change ...
    assert [a[0] for a in loads] == [str(second)]
    core.reconfigure(change)                          # ... then applies it at the next sample
    core.update(sample())
    assert core.params['backemf_table_path'] == str(second) and core.backemf is not None
    assert len(loads) == 1                            # read once, by check


def test_modes_are_built_then_configured_and_reconfigured_in_place(trap_table):
    from dtc_controller.core.modes import MODE_CLASSES, mode_class
    params = DTC_SCHEMA.validate_changes(DTC_SCHEMA.defaults(), {'mode': 'two_phase_four_switch', 'torque_band': 0.02})
    mode = mode_class('two_phase_four_switch').create(params, trap_table)
    K = mode.kernel
    assert mode.split_now is mode.split_select[1] and mode._prm[K.P_SPLIT_BAND] == pytest.approx(0.02 / 1000.0)
    mode.configure(dict(params, rotation=-1, torque_band=0.04))
    assert mode.split_now is mode.split_select[-1] and mode.select_now is mode.select_tables[-1]
    assert mode._prm[K.P_SPLIT_BAND] == pytest.approx(0.04 / 1000.0) and mode._prm[K.P_TORQUE_BAND] == 0.04
    assert set(MODE_CLASSES) == set(DTC_SCHEMA['mode'].choices)
    with pytest.raises(ValueError, match="unknown mode 'no_such_mode'"):
        mode_class('no_such_mode')
