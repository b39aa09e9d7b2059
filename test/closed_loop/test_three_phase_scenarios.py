"""The shipped three-phase scenarios (000 ch. V, 001 Tables IX-X), headless with reduced durations.

Each test loads a scenario file from drive_bringup/scenarios, shortens it (the
full-length runs are the reproduction command's job: run_scenario / report),
runs it through run_headless and checks the behaviour with physics bounds
using the metrics of drive_analysis.metrics.three_phase and .ripple. The metric functions
themselves are pinned first on synthetic signals with known answers.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

pytest.importorskip('bldc_plant_sim.core.cosim')

from drive_analysis.metrics import ripple  # noqa: E402
from drive_analysis.metrics import three_phase as m  # noqa: E402
from drive_analysis.metrics import two_phase  # noqa: E402
from drive_analysis.registry import lookup  # noqa: E402
from drive_bringup.headless import run_headless  # noqa: E402
from drive_bringup.report import check_rows, evaluate_metrics  # noqa: E402
from drive_bringup.scenario import Event, find_scenario, load_scenario, scenario_dir  # noqa: E402

MINE = sorted(p.stem for pat in ('three_phase_*.yaml', 'fstp_*.yaml', 'sstp_*.yaml')
              for p in scenario_dir().glob(pat))
L_000 = 1.0875e-3                     # H, L - M of the 000 motor
PSI_M_001 = 0.0928                    # Wb, 001 Table VIII


def _run(name: str, duration: float, events=None) -> dict:
    sc = load_scenario(find_scenario(name)).shortened(duration)
    if events is not None:
        sc = dataclasses.replace(sc, events=events)
    return run_headless(sc).arrays()


# ---------------------------------------------------------------------------- files
def test_shipped_scenarios_are_valid_and_name_known_metrics():
    assert {'three_phase_dtifc_sensorless', 'three_phase_dtifc_field_weakening', 'fstp_current_model_full_load',
            'fstp_voltage_model_no_compensation', 'fstp_voltage_model_simple_compensation',
            'fstp_voltage_model_proposed_compensation', 'sstp_current_model_full_load',
            'sstp_voltage_model_no_compensation', 'sstp_voltage_model_simple_compensation'} <= set(MINE)
    for name in MINE:
        sc = load_scenario(find_scenario(name))
        assert sc.name == name and sc.seed_reference and sc.description and sc.checks
        for metric in set(sc.metrics) | {c.metric for c in sc.checks}:
            fn = lookup((sc.metrics.get(metric) or {}).get('metric', metric))   # aliases
            assert fn.__module__.startswith('drive_analysis.metrics.'), (name, metric)


# ---------------------------------------------------------------------------- metrics on known signals
def _synthetic(n_periods=10, f=25.0, dt=50e-6, amps=(2.0, 2.1, 2.2), h5=0.1, ripple=0.06):
    t = np.arange(int(round(n_periods / (f * dt)))) * dt
    th = 2 * np.pi * f * t
    cur = np.stack([a * np.sin(th - k * 2 * np.pi / 3) + h5 * a * np.sin(5 * (th - k * 2 * np.pi / 3))
                    for k, a in enumerate(amps)], axis=1)
    torque = 0.3 + ripple / 2 * np.sin(6 * th)
    steps = np.arange(len(t))
    err = np.radians(3.0) * np.sin(th)                        # angle error of RMS 3/sqrt(2) deg
    psi = 0.07 * (1 + 0.01 * np.cos(6 * th))
    return {'plant/state.time': t, 'plant/state.step': steps, 'plant/state.phase_current': cur,
            'plant/state.electromagnetic_torque': torque, 'plant/state.mechanical_speed': np.full(len(t), 2 * np.pi * f),
            'plant/state.rotor_angle': th % (2 * np.pi),
            'dtc/status.time': t, 'dtc/status.step': steps, 'dtc/status.torque_estimate': torque * 1.05,
            'dtc/status.rotor_angle_estimate': (th + err) % (2 * np.pi),
            'dtc/status.flux_alpha': psi * np.cos(th), 'dtc/status.flux_beta': psi * np.sin(th),
            'dtc/status.d_current': np.sin(40 * th), 'dtc/status.d_current_reference': np.zeros(len(t))}


def test_metrics_on_synthetic_signals():
    a = _synthetic()
    for ph, amp in zip('abc', (2.0, 2.1, 2.2)):
        assert m.phase_current_fundamental_A(a, ph) == pytest.approx(amp, rel=1e-6)
    assert m.phase_b_current_fundamental_A(a) == pytest.approx(2.1, rel=1e-6)
    assert m.current_imbalance(a) == pytest.approx(0.2 / 2.1, rel=1e-6)
    assert m.current_thd_percent(a) == pytest.approx(10.0, rel=1e-6)          # eq. (39): 5th at 10 %
    assert m.current_thd_percent(a, max_order=4) == pytest.approx(0.0, abs=1e-6)
    assert ripple.torque_ripple_factor_median_period_percent(a) == pytest.approx(20.0, rel=1e-3)  # eq. (40): 0.06 / 0.3
    assert m.predicted_minus_actual_torque_pct(a) == pytest.approx(5.0, rel=1e-9)
    assert m.angle_error_rms_deg(a) == pytest.approx(3.0 / math.sqrt(2), rel=1e-3)
    assert m.angle_error_max_deg(a) == pytest.approx(3.0, rel=1e-3)
    assert m.flux_locus_mean_radius_Wb(a) == pytest.approx(0.07, rel=1e-3)
    assert m.flux_locus_radius_variation(a) == pytest.approx(0.02, rel=0.05)
    assert m.flux_locus_dominant_order(a) == 6.0
    assert m.flux_locus_shape_correlation(a, (0.0, 0.2), (0.2, 0.4)) == pytest.approx(1.0, abs=1e-3)
    assert m.d_current_mean_A(a) == pytest.approx(0.0, abs=0.01)
    assert m.d_current_positive_fraction(a) == pytest.approx(0.5, abs=0.01)
    assert math.isnan(m.angle_error_rms_deg(a, t_start=10.0))


# ---------------------------------------------------------------------------- 000 ch. V
def test_dtifc_sensorless_scenario_reduced():
    """000 Figs. 5.5, 5.7, 5.8, 5.11 in 0.3 s (step of T* at 0.2 s instead of 0.65 s)."""
    a = _run('three_phase_dtifc_sensorless', 0.3,
             [Event(0.2, 'dtc_controller', {'torque_reference': 0.6375})])
    steady = dict(t_start=0.05, t_end=0.2)
    assert m.angle_error_rms_deg(a, t_start=0.05) < 5.0
    assert abs(m.d_current_mean_A(a, **steady)) < 0.2
    assert 0.3 < m.d_current_positive_fraction(a, **steady) < 0.7
    assert m.d_current_mean_A(a, source='plant', **steady) == pytest.approx(0.0, abs=0.3)
    assert two_phase.torque_estimation_rms_error_pct_rated(a, t_start=0.05) < 2.0
    assert two_phase.mean_torque_N_m(a, **steady) == pytest.approx(0.51, abs=0.02)
    assert two_phase.mean_torque_N_m(a, t_start=0.22) == pytest.approx(0.6375, abs=0.03)
    # i_d = 0: |psi_s| = |psi_r + L i_q| ~ rotor-flux amplitude 7 pi k_LL / 36 (k_LL = 0.1146 V s/rad)
    psi_r = 7 * math.pi * 0.1146 / 36
    assert m.flux_locus_mean_radius_Wb(a, **steady) == pytest.approx(psi_r, rel=0.05)
    assert m.flux_locus_mean_radius_Wb(a, source='plant', **steady) == pytest.approx(psi_r, rel=0.05)
    # not a circle: the ideal trapezoid's rounded hexagon, (max - min) / mean about 0.012
    assert 0.009 <= m.flux_locus_radius_variation(a, **steady) <= 0.015
    assert two_phase.mean_speed_rad_s(a, **steady) == pytest.approx(30.0, abs=0.5)  # dynamometer
    assert m.flux_locus_dominant_order(a, **steady) == 6.0
    assert abs(m.speed_estimate_error_pct(a, t_start=0.1, t_end=0.2, pole_pairs=2)) < 5.0


def test_dtifc_field_weakening_scenario():
    """000 Fig. 5.6 (full 0.3 s): i_d* 0 -> -5 A shrinks the locus by L |i_d*|, same shape."""
    sc = load_scenario(find_scenario('three_phase_dtifc_field_weakening'))
    a = run_headless(sc).arrays()
    rows = check_rows(sc, evaluate_metrics(sc, a))              # the report's own checks pass
    assert rows and all(r['pass'] for r in rows), [r for r in rows if not r['pass']]
    before, after = (0.005, 0.125), (0.15, 0.3)
    r0 = m.flux_locus_mean_radius_Wb(a, *before)
    r1 = m.flux_locus_mean_radius_Wb(a, *after)
    assert r0 - r1 == pytest.approx(L_000 * 5.0, rel=0.1)
    assert m.flux_locus_shape_correlation(a, before, after) > 0.9
    assert m.d_current_mean_A(a, *after) == pytest.approx(-5.0, abs=0.2)
    assert m.angle_error_rms_deg(a, t_start=0.02) < 5.0
    assert two_phase.mean_torque_N_m(a, *after) == pytest.approx(0.51, abs=0.03)


# ---------------------------------------------------------------------------- 001 Tables IX-X
@pytest.fixture(scope='module')
def fstp_runs():
    """The four FSTP scenarios shortened to 1.0 s; metrics over the last 0.3 s (7.5 periods at 25 Hz)."""
    out = {}
    for key, name in (('current', 'fstp_current_model_full_load'), ('none', 'fstp_voltage_model_no_compensation'),
                      ('simple', 'fstp_voltage_model_simple_compensation'),
                      ('proposed', 'fstp_voltage_model_proposed_compensation')):
        a = _run(name, 1.0)
        w = dict(t_start=0.7, t_end=1.0)
        out[key] = {'amps': [m.phase_current_fundamental_A(a, p, **w) for p in 'abc'],
                    'imbalance': m.current_imbalance(a, **w),
                    'offset': m.predicted_minus_actual_torque_pct(a, **w),
                    'torque': two_phase.mean_torque_N_m(a, **w),
                    'thd': m.current_thd_percent(a, **w),
                    'trf': ripple.torque_ripple_factor_median_period_percent(a, **w),
                    'speed': two_phase.mean_speed_rad_s(a, **w)}
    return out


def test_fstp_shaft_delivers_rated_torque_at_1500_rpm(fstp_runs):
    for key, r in fstp_runs.items():
        assert r['speed'] == pytest.approx(50 * math.pi, abs=1.0), key
        # speed PI against the 0.3 N m load + friction 1e-5 * 157 rad/s
        assert r['torque'] == pytest.approx(0.3 + 1e-5 * 50 * math.pi, abs=0.005), key
        assert 30.0 < r['trf'] < 120.0, key


def test_fstp_current_model_balanced_near_demand(fstp_runs):
    r = fstp_runs['current']
    demand = r['torque'] / (1.5 * PSI_M_001)                   # 2.17 A peak
    assert all(abs(x - demand) < 0.1 * demand for x in r['amps'])
    assert 2.0 < min(r['amps']) and max(r['amps']) < 2.3
    assert r['imbalance'] < 0.05 and abs(r['offset']) < 1.0 and r['thd'] < 10.0


def test_fstp_voltage_model_compensation_ordering(fstp_runs):
    none, simple, proposed = fstp_runs['none'], fstp_runs['simple'], fstp_runs['proposed']
    assert proposed['imbalance'] < simple['imbalance'] < none['imbalance']
    assert none['imbalance'] > 0.2 and proposed['imbalance'] < 0.10
    assert none['offset'] > 5.0                                 # predicted torque above actual
    assert 0.0 < simple['offset'] < none['offset']
    assert abs(proposed['offset']) < 2.0                        # within 2 % of actual
    assert proposed['thd'] < simple['thd'] < none['thd']
    assert np.mean(none['amps']) > np.mean(proposed['amps'])    # over-prediction costs current


def test_sstp_voltage_model_without_compensation_overpredicts_but_stays_balanced():
    out = {}
    for key, name in (('none', 'sstp_voltage_model_no_compensation'),
                      ('simple', 'sstp_voltage_model_simple_compensation')):
        a = _run(name, 1.0)
        w = dict(t_start=0.7, t_end=1.0)
        out[key] = (m.predicted_minus_actual_torque_pct(a, **w), m.current_imbalance(a, **w),
                    min(m.phase_current_fundamental_A(a, p, **w) for p in 'abc'))
    assert out['none'][0] > 5.0 and out['none'][1] < 0.1 and out['none'][2] > 2.4
    assert 0.0 < out['simple'][0] < out['none'][0] and out['simple'][1] < 0.1

