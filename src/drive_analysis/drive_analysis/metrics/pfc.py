"""Metrics of the boost PFC results (000 ch. III, Figs. 3.4-3.6), pure numpy.

The contract: :mod:`drive_analysis.metrics`. Line-side metrics use :mod:`drive_common.signals`
over the last whole line cycles of the window; definitions: docs/reference/metrics.md "Boost PFC".
"""
from __future__ import annotations

import math

import numpy as np

from drive_analysis.arrays import field, moving_average
from drive_common import signals

LINE_FREQUENCY = 60.0


def _plant(arrays: dict, name: str, t_start=None, t_end=None) -> tuple[np.ndarray, np.ndarray]:
    """(t, plant/state.<name> as floats) within the window."""
    t, x = field(arrays, name, t_start, t_end)
    return t, x.astype(float, copy=False)


def _grid(arrays: dict, t_start=None, t_end=None, cycles=None,
          line_frequency: float = LINE_FREQUENCY):
    """(v, i, periods) over the last whole line cycles of the window."""
    t, v = _plant(arrays, 'grid_voltage', t_start, t_end)
    i = _plant(arrays, 'grid_current', t_start, t_end)[1]
    if len(t) < 3:
        raise ValueError('window holds too few samples')
    dt = np.diff(t)
    # The headless runner appends the final state; keep only the evenly spaced part.
    step = float(np.median(dt))
    if not abs(dt[-1] - step) < 1e-3 * step:
        v, i = v[:-1], i[:-1]
    n, periods = signals.samples_per_whole_periods(len(v), 1.0 / step / line_frequency, cycles)
    v, i = v[len(v) - n:], i[len(i) - n:]
    if np.isnan(v).any() or np.isnan(i).any():
        raise ValueError('no grid quantities recorded (front end disabled?)')
    return v, i, periods


def _line_metric(quantity):
    """A metric of (v, i, periods) over the last whole line cycles of the window (see :func:`_grid`)."""
    def metric(arrays, t_start=None, t_end=None, cycles=None, line_frequency=LINE_FREQUENCY) -> float:
        return float(quantity(*_grid(arrays, t_start, t_end, cycles, line_frequency)))
    return metric


line_power_factor = _line_metric(lambda v, i, periods: signals.power_factor(v, i))
line_displacement_factor = _line_metric(signals.displacement_factor)
line_current_rms_A = _line_metric(lambda v, i, periods: signals.rms(i))
line_voltage_rms_V = _line_metric(lambda v, i, periods: signals.rms(v))
line_real_power_W = _line_metric(lambda v, i, periods: np.mean(v * i))
line_current_mean_A = _line_metric(lambda v, i, periods: np.mean(i))
"""DC component of the line current over whole cycles (0 when both half cycles conduct alike)."""


def line_current_thd_pct(arrays, t_start=None, t_end=None, cycles=None,
                         line_frequency=LINE_FREQUENCY, max_harmonic=40) -> float:
    _, i, periods = _grid(arrays, t_start, t_end, cycles, line_frequency)
    return 100.0 * signals.thd(i, periods, max_harmonic)


def _window_metric(name: str, reduce):
    """A metric reducing plant/state.<name> over the window (NaN when it holds no sample)."""
    def metric(arrays, t_start=None, t_end=None) -> float:
        x = _plant(arrays, name, t_start, t_end)[1]
        return float(reduce(x)) if len(x) else math.nan
    return metric


mean_output_voltage_V = _window_metric('dc_link_voltage', np.mean)
output_voltage_ripple_pp_V = _window_metric('dc_link_voltage', np.ptp)
max_output_voltage_V = _window_metric('dc_link_voltage', np.max)
min_output_voltage_V = _window_metric('dc_link_voltage', np.min)
boost_switch_enabled_fraction = _window_metric('boost_switch_enabled', np.mean)
peak_inductor_current_A = _window_metric('inductor_current', np.max)


def _averaged_output(arrays, t_start, t_end, line_frequency):
    """(t, v_o averaged over a trailing half line cycle) in the window."""
    t, v = _plant(arrays, 'dc_link_voltage', t_start, t_end)
    if len(t) < 3:
        return t, v
    step = float(np.median(np.diff(t)))
    n = max(1, int(round(0.5 / line_frequency / step)))
    if len(v) <= n:
        return t[-1:], np.array([np.mean(v)])
    return t[n - 1:], moving_average(v, n)


def output_recovery_time_s(arrays, t_event, reference=80.0, band=2.0, t_end=None,
                           line_frequency=LINE_FREQUENCY) -> float:
    t, avg = _averaged_output(arrays, t_event, t_end, line_frequency)
    if not len(t):
        return math.nan
    outside = np.abs(avg - reference) > band
    if not outside.any():
        return 0.0
    if outside[-1]:
        return math.nan
    last = int(np.flatnonzero(outside)[-1])
    return float(t[last + 1] - t_event)


def output_voltage_deviation_V(arrays, t_event=None, reference=80.0, t_start=None, t_end=None,
                               line_frequency=LINE_FREQUENCY) -> float:
    start = t_event if t_event is not None else t_start
    t, avg = _averaged_output(arrays, start, t_end, line_frequency)
    return float(np.max(np.abs(avg - reference))) if len(t) else math.nan


def final_time_s(arrays) -> float:
    t = np.asarray(arrays['plant/state.time'], dtype=float)
    return float(t[-1]) if len(t) else math.nan
