"""Seed metrics on signals with known answers (001 eqs. 39-40, PF, rise time, errors)."""
import math

import numpy as np
import pytest

from drive_analysis import arrays
from drive_analysis import summary as metrics


def test_thd_of_known_harmonics_eq39():
    f1 = 50.0
    t = np.arange(0, 0.1, 1e-5)
    x = 2.0 * np.sin(2 * np.pi * f1 * t) + 0.2 * np.sin(2 * np.pi * 5 * f1 * t) + 0.1 * np.cos(2 * np.pi * 7 * f1 * t)
    assert metrics.thd_percent(t, x, f1) == pytest.approx(math.hypot(0.2, 0.1) / 2.0 * 100, rel=1e-3)
    assert metrics.harmonics(t, x + 0.5, f1, 1)[0] == pytest.approx(0.5, abs=1e-6)


def test_fundamental_frequency_and_balance():
    t = np.arange(0, 0.2, 2e-5)
    amps = (2.0, 2.2, 1.8)
    phases = [a * np.sin(2 * np.pi * 83.0 * t - k * 2 * np.pi / 3) for k, a in enumerate(amps)]
    assert metrics.fundamental_frequency(t, phases[0]) == pytest.approx(83.0, rel=0.03)
    fund = [metrics.harmonics(t, p, 83.0, 1)[1] for p in phases]
    assert fund == pytest.approx(amps, rel=1e-3)
    assert metrics.current_balance(fund)['imbalance_percent'] == pytest.approx(0.4 / 2.0 * 100, rel=1e-3)


def test_trf_eq40_and_ripple():
    torque = 0.3 + 0.015 * np.sin(np.linspace(0, 12 * np.pi, 6000, endpoint=False))
    assert metrics.torque_ripple_factor_window_percent(torque, 0.3) == pytest.approx(0.03 / 0.3 * 100, rel=1e-3)
    r = metrics.ripple(torque)
    assert r['peak_to_peak'] == pytest.approx(0.03, rel=1e-3)
    assert r['rms_deviation'] == pytest.approx(0.015 / math.sqrt(2), rel=1e-2)


def test_power_factor_of_shifted_sine():
    t = np.arange(0, 0.1, 1e-5)
    v = 100 * np.sin(2 * np.pi * 60 * t)
    i = 3 * np.sin(2 * np.pi * 60 * t - 0.5)
    assert metrics.power_factor(t, v, i, 60.0) == pytest.approx(math.cos(0.5), abs=1e-3)


def test_rise_time_of_first_order_response():
    tau = 1e-3
    t = np.arange(0, 0.02, 1e-6)
    ref = np.where(t < 0.005, 0.5, 1.0)
    y = np.where(t < 0.005, 0.5, 1.0 - 0.5 * np.exp(-(t - 0.005) / tau))
    start, before, after = arrays.largest_step(ref)
    assert (t[start], before, after) == (pytest.approx(0.005, abs=2e-6), 0.5, 1.0)
    assert arrays.response_time(t, y, start, before, after, high=0.9, low=0.1) == pytest.approx(
        tau * math.log(9), rel=1e-2)
    assert arrays.response_time(t, y, start, before, after, high=0.9) == pytest.approx(
        tau * math.log(10), rel=1e-2)
    assert math.isnan(arrays.response_time(t, y, start, before, 2.0))   # never reached
    assert arrays.largest_step(np.full(5, 0.5)) is None


def test_angle_error_wraps():
    est = np.array([0.05, 2 * np.pi - 0.05, np.nan])
    true = np.array([2 * np.pi - 0.05, 0.05, 1.0])
    stats = metrics.error_stats(est, true, angle=True)
    assert stats['samples'] == 2
    assert stats['max_abs'] == pytest.approx(0.1)
    assert stats['mean'] == pytest.approx(0.0, abs=1e-12)
