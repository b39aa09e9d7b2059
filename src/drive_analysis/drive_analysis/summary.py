"""The ``analyze`` summary: seed metrics on plain numpy arrays of a bag (SI units, no ROS).

Phase-current THD per phase and in total (001 eq. (39)), the torque ripple factor over the
window (001 eq. (40)), power factor over whole line periods (000 ch. III), torque rise time
(10-90 %), ripple, current balance and estimation errors against ground truth. Harmonics are the
DFT (:mod:`drive_common.signals`) of the signal resampled uniformly over whole fundamental
periods (no leakage). The scenarios' metrics are in :mod:`drive_analysis.metrics`.
"""
from __future__ import annotations

import math

import numpy as np

from drive_analysis.arrays import (DTC, PLANT, field, flatten_columns, largest_step, paired,
                                   response_time)
from drive_common import signals


def fundamental_frequency(t: np.ndarray, x: np.ndarray) -> float:
    """Hz, frequency of the largest non-DC spectral peak of x(t) (uniformly resampled)."""
    t, x = np.asarray(t, float), np.asarray(x, float)
    n = len(t)
    if n < 8:
        raise ValueError('too few samples for a spectrum')
    grid = np.linspace(t[0], t[-1], n)
    y = np.interp(grid, t, x)
    spectrum = np.abs(np.fft.rfft(y - y.mean()))
    k = int(np.argmax(spectrum[1:]) + 1)
    return k / (grid[-1] - grid[0]) * (n - 1) / n


def whole_periods(t: np.ndarray, f1: float) -> tuple[float, float]:
    """(t_start, t_end) of the last whole number of periods of f1 inside t."""
    span = t[-1] - t[0]
    periods = math.floor(span * f1 + 1e-9)
    if periods < 1:
        raise ValueError(f'window of {span:.4g} s holds no whole period at {f1:.4g} Hz')
    return t[-1] - periods / f1, t[-1]


def harmonics(t, x, f1: float, n_max: int = 40, points_per_period: int = 256) -> np.ndarray:
    """Peak amplitudes X_0..X_n_max of x(t) at multiples of f1 (X_0 = mean), from x resampled
    uniformly over the last whole periods of f1."""
    t, x = np.asarray(t, float), np.asarray(x, float)
    t0, t1 = whole_periods(t, f1)
    periods = round((t1 - t0) * f1)
    m = periods * max(points_per_period, 2 * n_max + 2)
    y = np.interp(t0 + np.arange(m) * (t1 - t0) / m, t, x)
    return np.abs(signals.harmonics(y, periods, n_max))


def thd_percent(t, x, f1: float, n_max: int = 40) -> float:
    """001 eq. (39), one phase: sqrt(sum_{n=2}^{n_max} X_n^2) / X_1 * 100 %."""
    return signals.thd_of(harmonics(t, x, f1, n_max)) * 100.0


def torque_ripple_factor_window_percent(torque, rated_torque: float) -> float:
    """001 eq. (40) over a whole window: TRF = (T_max - T_min) / T_rated * 100 %.

    The scenarios' per-period variant is ``metrics.ripple.torque_ripple_factor_median_period_percent``.
    """
    torque = np.asarray(torque, float)
    return float((np.max(torque) - np.min(torque)) / rated_torque * 100.0)


def ripple(x) -> dict:
    """Peak-to-peak and RMS deviation about the mean of a steady-state signal."""
    x = np.asarray(x, float)
    return {'mean': float(np.mean(x)), 'peak_to_peak': float(np.ptp(x)),
            'rms_deviation': float(np.sqrt(np.mean((x - x.mean()) ** 2)))}


def power_factor(t, v, i, f1: float) -> float:
    """PF = mean(v i) / (V_rms I_rms) over whole periods of the line frequency f1 (resampled)."""
    t, v, i = (np.asarray(a, float) for a in (t, v, i))
    t0, t1 = whole_periods(t, f1)
    grid = np.linspace(t0, t1, max(len(t), 1000), endpoint=False)
    return signals.power_factor(np.interp(grid, t, v), np.interp(grid, t, i))


def current_balance(fundamentals) -> dict:
    """Fundamental amplitude per phase and the imbalance (max - min) / mean * 100 %."""
    f = np.asarray(fundamentals, float)
    return {'fundamental_amplitudes': [float(a) for a in f],
            'imbalance_percent': float((f.max() - f.min()) / f.mean() * 100.0)}


def error_stats(estimate, truth, angle: bool = False) -> dict:
    """Mean, RMS and max |error| of estimate - truth (angles wrapped), NaN samples skipped."""
    err = np.asarray(estimate, float) - np.asarray(truth, float)
    if angle:
        err = signals.wrap_to_pi(err)
    err = err[~np.isnan(err)]
    if not len(err):
        return {'mean': float('nan'), 'rms': float('nan'), 'max_abs': float('nan'), 'samples': 0}
    return {'mean': float(np.mean(err)), 'rms': signals.rms(err),
            'max_abs': float(np.max(np.abs(err))), 'samples': int(len(err))}


def _safe(fn, *args, **kwargs):
    try:
        return fn(*args, **kwargs)
    except (ValueError, ZeroDivisionError, IndexError, FloatingPointError) as exc:
        return {'error': str(exc)}


def _phase_currents(out: dict, t, currents) -> None:
    """Fundamental frequency, THD per phase and in total (001 eq. (39)) and balance, from one
    resampled spectrum per phase."""
    i_ref = currents[:, int(np.nanargmax(np.nanstd(currents, axis=0)))]
    f1 = _safe(fundamental_frequency, t, i_ref)
    if not isinstance(f1, float):
        return
    out['current_fundamental_frequency'] = f1
    spectra = [_safe(harmonics, t, currents[:, k], f1) for k in range(3)]
    thd = [_safe(lambda h: signals.thd_of(h) * 100.0, h) if isinstance(h, np.ndarray) else h
           for h in spectra]
    out['current_thd_percent'] = dict(zip('abc', thd))
    if all(isinstance(x, float) for x in thd):
        out['current_thd_total_percent'] = signals.total_thd(thd)
    if all(isinstance(h, np.ndarray) for h in spectra):
        out['current_balance'] = current_balance([float(h[1]) for h in spectra])


def _steady_state(out: dict, arrays, t0: float, t1: float, rated_torque, line_frequency) -> None:
    """Currents, torque and speed ripple, and the line side over the steady-state window."""
    t, currents = field(arrays, 'phase_current', t0, t1)
    _phase_currents(out, t, currents)
    torque = field(arrays, 'electromagnetic_torque', t0, t1)[1]
    out['torque_ripple'] = ripple(torque)
    if rated_torque:
        out['torque_ripple_factor_window_percent'] = torque_ripple_factor_window_percent(torque, rated_torque)
    out['speed_ripple'] = ripple(field(arrays, 'mechanical_speed', t0, t1)[1])
    if f'{PLANT}.grid_voltage' in arrays:
        grid_v = field(arrays, 'grid_voltage', t0, t1)[1]
        grid_i = field(arrays, 'grid_current', t0, t1)[1]
        if np.isfinite(grid_v).all() and np.isfinite(grid_i).all():
            out['power_factor'] = _safe(power_factor, t, grid_v, grid_i, line_frequency)
            out['grid_current_thd_percent'] = _safe(thd_percent, t, grid_i, line_frequency)


def _controller(out: dict, arrays) -> None:
    """Torque step response (10-90 %), estimation errors against ground truth, flux ripple."""
    status_t = np.asarray(arrays[f'{DTC}.time'], dtype=float)
    step = largest_step(arrays[f'{DTC}.torque_reference'])
    has_state = f'{PLANT}.time' in arrays
    if step is not None and has_state:
        index, before, after = step
        t_step = float(status_t[index])
        t = np.asarray(arrays[f'{PLANT}.time'], dtype=float)
        start = int(np.searchsorted(t, t_step - 1e-12))
        out['torque_step'] = {'time': t_step, 'from': before, 'to': after,
                              'rise_time_10_90': response_time(
                                  t, arrays[f'{PLANT}.electromagnetic_torque'], start, before,
                                  after, high=0.9, low=0.1)}
    if has_state:
        d = paired(arrays)
        out['torque_estimation_error'] = error_stats(d['dtc.torque_estimate'],
                                                     d['plant.electromagnetic_torque'])
        out['angle_estimation_error'] = error_stats(d['dtc.rotor_angle_estimate'],
                                                    d['plant.rotor_angle'], angle=True)
    flux = np.asarray(arrays[f'{DTC}.flux_magnitude'], dtype=float)
    out['flux_ripple'] = ripple(flux[np.isfinite(flux)]) if np.isfinite(flux).any() else None


def summarize(cols, rated_torque=None, window=None, line_frequency=60.0) -> dict:
    """The metrics of a run's columns ({topic: {field: array}}, see the module docstring)."""
    out: dict = {'topics': {t: int(len(c.get('step', []))) for t, c in cols.items()}}
    arrays = flatten_columns(cols)
    t = arrays.get(f'{PLANT}.time')
    if t is not None and len(t) > 8:
        t0, t1 = window or (t[0] + 0.5 * (t[-1] - t[0]), t[-1])
        out['window'] = [float(t0), float(t1)]
        _steady_state(out, arrays, t0, t1, rated_torque, line_frequency)
    if len(arrays.get(f'{DTC}.time', ())) > 1:
        _controller(out, arrays)
    return out


def json_safe(value):
    """JSON-safe copy: NaN/inf -> None, numpy scalars -> Python numbers."""
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value
