"""Boost PFC closed loop (000 ch. III): plant with front end + pfc_controller + two-phase DTC, headless.

Reduced versions of the shipped ``pfc_*`` scenarios (fewer line cycles, events
moved earlier): the plain rectifier of Fig. 3.4, the PFC of Fig. 3.5 holding
80 V with a sinusoidal line current, a load step, and the induced boost
over-current (over-load step) / over-voltage (load dump) trips at the default
8 A / 140 V limits, after which the run goes on with the boost held off.
The full scenarios (checks against the seed values) run with the reproduce
command; these keep the suite under about a minute.
"""
from __future__ import annotations

import dataclasses
import functools

import pytest

from drive_analysis.registry import lookup
from drive_bringup.headless import run_headless
from drive_bringup.report import evaluate_metrics
from drive_bringup.scenario import Event, find_scenario, load_scenario

PFC_SCENARIOS = ('pfc_without_pfc_fig_3_4', 'pfc_no_load_fig_3_5', 'pfc_load_fig_3_6',
                 'pfc_load_and_line_steps', 'pfc_protection_trips', 'pfc_seed_structure_only')


@functools.lru_cache(maxsize=None)
def _run(name: str, duration: float, events: tuple = (), metrics: tuple = ()):
    """Scenario `name` shortened to `duration` with `events` instead of its own; metric values."""
    sc = load_scenario(find_scenario(name)).shortened(duration)
    sc = dataclasses.replace(sc, events=[Event(t, node, dict(params)) for t, node, params in events],
                             metrics={k: dict(v) for k, v in metrics}, checks=[])
    result = run_headless(sc)
    arrays = result.arrays()
    values = evaluate_metrics(sc, arrays)
    return values, arrays


def _values(name, duration, events=(), **spec):
    values, arrays = _run(name, duration, tuple(events),
                          tuple((k, tuple(sorted(v.items()))) for k, v in spec.items()))
    for k, v in values.items():
        assert isinstance(v, float), (k, v)
    return values, arrays


@pytest.mark.parametrize('name', PFC_SCENARIOS)
def test_shipped_scenarios_are_complete(name):
    sc = load_scenario(find_scenario(name))
    assert sc.name == name and sc.seed_reference.startswith('000')
    assert len(sc.description) > 200 and sc.checks
    plant = sc.node_parameters['plant']
    assert plant['front_end.enabled'] and plant['dc_link.mode'] == 'current_fed'
    assert plant['base_tick'] == 12.5e-6 and plant['dtc_period'] == 25e-6
    assert sc.node_parameters['dtc_controller']['mode'] == 'two_phase_six_switch'
    assert sc.node_parameters['dtc_controller']['backemf_table_path'].endswith(
        'ozturk_bldc_backemf.csv')
    assert ('pfc_controller' in sc.node_parameters) == (name != 'pfc_without_pfc_fig_3_4')
    for label, options in sc.metrics.items():
        lookup((options or {}).get('metric', label))
    for check in sc.checks:
        lookup((sc.metrics.get(check.metric) or {}).get('metric', check.metric))


def test_without_pfc_the_rectifier_current_is_distorted():
    """000 Fig. 3.4 (64.53 V RMS, boost off): PF near 0.77, THD far above 30 %."""
    w = {'t_start': 0.2}
    v, _ = _values('pfc_without_pfc_fig_3_4', 0.25, line_power_factor=w, line_current_thd_pct=w,
                   mean_output_voltage_V=w, line_current_mean_A=w,
                   boost_switch_enabled_fraction={})
    assert 0.70 <= v['line_power_factor'] <= 0.84, v
    assert v['line_current_thd_pct'] > 60.0, v
    assert abs(v['line_current_mean_A']) < 0.05, v          # both half cycles conduct
    assert 72.0 < v['mean_output_voltage_V'] < 88.0, v
    assert v['boost_switch_enabled_fraction'] == 0.0


def test_with_pfc_the_output_is_held_and_the_line_current_is_sinusoidal():
    """000 Fig. 3.5 (25.43 V RMS): V_o 80 V, PF >= 0.99, THD <= 8 % (seed 0.9997, 5.45 %)."""
    w = {'t_start': 0.55}
    v, arrays = _values('pfc_no_load_fig_3_5', 0.6, line_power_factor=w, line_current_thd_pct=w,
                        mean_output_voltage_V=w, line_real_power_W=w,
                        boost_protection_tripped={'metric': 'protection_tripped', 'bit': 6})
    assert abs(v['mean_output_voltage_V'] - 80.0) < 2.0, v
    assert v['line_power_factor'] >= 0.99, v
    assert v['line_current_thd_pct'] <= 8.5, v
    assert 55.0 < v['line_real_power_W'] < 85.0, v
    assert v['boost_protection_tripped'] == 0.0
    assert arrays['pfc/status.enabled'].all()


def test_load_step_output_recovers():
    w = {'t_start': 0.55}
    v, _ = _values('pfc_no_load_fig_3_5', 0.6,
                   events=((0.35, 'dtc_controller', (('torque_reference', 0.573),)),),
                   after={'metric': 'output_voltage_deviation_V', 't_event': 0.5},
                   dev={'metric': 'output_voltage_deviation_V', 't_event': 0.35},
                   mean_output_voltage_V=w, boost_protection_tripped={'metric': 'protection_tripped', 'bit': 6})
    assert v['dev'] > 3.0, v                 # the step did disturb the output
    assert v['after'] < 6.0, v               # and it is back near 80 V
    assert abs(v['mean_output_voltage_V'] - 80.0) < 3.0, v
    assert v['boost_protection_tripped'] == 0.0


def test_physical_trips_at_the_default_limits():
    """Over-load step -> 8 A over-current (cycle by cycle); load dump -> 140 V over-voltage (latched)."""
    events = ((0.3, 'dtc_controller', (('torque_reference', 0.9),)),
              (0.35, 'dtc_controller', (('torque_reference', 0.4),)),
              (0.42, 'plant', (('front_end.protection_latched', True), ('load.mode', 'torque'),
                               ('load.torque', 0.0))),
              (0.42, 'dtc_controller', (('torque_reference', 0.0),)))
    v, arrays = _values(
        'pfc_protection_trips', 0.5, events=events,
        before={'metric': 'protection_tripped', 'bit': 6, 't_end': 0.3},
        oc={'metric': 'protection_tripped', 'bit': 2, 't_start': 0.3, 't_end': 0.35},
        peak={'metric': 'peak_inductor_current_A', 't_start': 0.3, 't_end': 0.35},
        ov_time={'metric': 'trip_time_s', 'bit': 4, 't_start': 0.42},
        on_at_end={'metric': 'boost_switch_enabled_fraction', 't_start': 0.46},
        final_time_s={})
    assert v['before'] == 0.0 and v['oc'] == 1.0, v
    assert 7.5 <= v['peak'] <= 8.1, v                       # held at the default 8 A level
    assert 0.42 < v['ov_time'] < 0.46, v                    # default 140 V level
    assert v['on_at_end'] == 0.0, v
    assert v['final_time_s'] == pytest.approx(0.5)
    assert arrays['plant/state.boost_duty'][-1] == 0.0
