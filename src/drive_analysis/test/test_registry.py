"""The metric registry (one lookup, one evaluate path) and the array helpers."""
import subprocess
import sys

import numpy as np
import pytest

from drive_analysis import arrays, registry


def _run(n=8):
    t = np.arange(n) * 0.1
    return {'plant/state.time': t, 'plant/state.step': np.arange(n), 'plant/state.mechanical_speed': t * 10.0,
            'plant/state.electromagnetic_torque': np.full(n, 0.2),
            'dtc/status.time': t[1:], 'dtc/status.step': np.arange(1, n), 'dtc/status.torque_estimate': t[1:],
            'dtc/status.torque_reference': np.full(n - 1, 0.2)}


def test_every_metric_module_contributes_and_names_are_unique():
    found = registry.metrics()
    modules = {fn.__module__ for fn in found.values()}
    assert modules == set(registry.METRIC_MODULES)
    assert 'rise_time_s' in found and 'line_power_factor' in found and 'current_thd_percent' in found
    assert 'torque_ripple_factor_median_period_percent' in found
    assert not any(name.startswith('_') for name in found)
    assert 'paired' not in found and 'window' not in found     # helpers are not metrics


def test_lookup_names_an_unknown_metric():
    with pytest.raises(KeyError, match="no metric named 'no_such_metric'"):
        registry.lookup('no_such_metric')


def test_evaluate_aliases_defaults_and_errors():
    run = _run()
    values = registry.evaluate({'speed_late': {'metric': 'mean_speed_rad_s', 't_start': 0.5},
                                'broken': {'metric': 'mean_speed_rad_s', 'no_such_option': 1}},
                               run, ['mean_speed_rad_s', 'no_such_metric'])
    assert values['speed_late'] == pytest.approx(np.mean([5.0, 6.0, 7.0]))
    assert values['mean_speed_rad_s'] == pytest.approx(3.5)
    assert values['broken'].startswith('error: TypeError')
    assert values['no_such_metric'].startswith('error: KeyError')


def test_window_includes_both_ends_and_paired_matches_steps():
    t = np.array([0.0, 0.1, 0.2, 0.3])
    assert arrays.window(t, 0.1, 0.2).tolist() == [False, True, True, False]
    assert arrays.window(t).all()
    d = arrays.paired(_run(), 0.2, 0.4)
    np.testing.assert_allclose(d['time'], [0.2, 0.3, 0.4])
    np.testing.assert_allclose(d['dtc.torque_estimate'], d['time'])      # status of step k at the plant's t_k
    assert 'plant.time' not in d and 'plant.step' in d and len(d) == 3
    assert d['plant.step'] is d['plant.step']        # a column is indexed once per pairing


def test_flatten_columns_and_last_whole_periods():
    flat = arrays.flatten_columns({'/plant/state': {'t': np.arange(3.0), 'step': np.arange(3)}})
    assert sorted(flat) == ['plant/state.step', 'plant/state.time']
    t = np.arange(105) * 1e-3
    run = {'plant/state.time': t, 'plant/state.x': np.sin(2 * np.pi * 50 * t)}
    tt, x, periods = arrays.last_whole_periods(run, 'x', frequency=50.0)
    assert periods == 5 and len(x) == 100 and tt[-1] == t[-1]
    assert arrays.last_whole_periods(run, 'x', frequency=5.0)[2] == 0


def test_analysis_imports_no_ros():
    code = ('import sys, drive_analysis.registry, drive_analysis.summary, drive_analysis.arrays;'
            'drive_analysis.registry.metrics(); sys.exit(1 if "rclpy" in sys.modules else 0)')
    subprocess.run([sys.executable, '-c', code], check=True)
