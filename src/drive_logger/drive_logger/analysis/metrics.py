"""Drive metrics of the seeds, on plain numpy arrays (SI units, no ROS).

- Phase-current THD and the three-phase THD: 001 eq. (39),
  ``THD_x = sqrt(sum_{n>=2} X_n^2) / X_1 * 100 %``,
  ``THD = sqrt((THD_A^2 + THD_B^2 + THD_C^2) / 3)``.
- Torque ripple factor: 001 eq. (40), ``TRF = T_pk-pk / T_rated * 100 %``.
- Power factor ``P / (V_rms I_rms)`` over whole line periods (000 ch. III).
- Torque rise time (10-90 %), ripple, current balance (fundamental per
  phase), estimation errors against ground truth (torque, wrapped angle).
Harmonics are the DFT of the signal resampled uniformly over a whole number
of fundamental periods, so there is no leakage for periodic signals.
"""
from __future__ import annotations

import math

import numpy as np


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
    """Peak amplitudes X_0..X_n_max of x(t) at multiples of f1 (X_0 = mean)."""
    t, x = np.asarray(t, float), np.asarray(x, float)
    t0, t1 = whole_periods(t, f1)
    periods = round((t1 - t0) * f1)
    m = periods * max(points_per_period, 2 * n_max + 2)
    grid = t0 + np.arange(m) * (t1 - t0) / m
    y = np.interp(grid, t, x)
    spectrum = np.fft.rfft(y) / m
    idx = np.arange(n_max + 1) * periods
    idx = idx[idx < len(spectrum)]
    amps = 2 * np.abs(spectrum[idx])
    amps[0] /= 2
    return amps


def thd_percent(t, x, f1: float, n_max: int = 40) -> float:
    """001 eq. (39), one phase: sqrt(sum_{n=2}^{n_max} X_n^2) / X_1 * 100 %."""
    amps = harmonics(t, x, f1, n_max)
    return float(math.sqrt(np.sum(amps[2:] ** 2)) / amps[1] * 100.0)


def total_thd_percent(phase_thds) -> float:
    """001 eq. (39): THD = sqrt((THD_A^2 + THD_B^2 + THD_C^2) / 3)."""
    phase_thds = np.asarray(phase_thds, float)
    return float(math.sqrt(np.mean(phase_thds ** 2)))


def torque_ripple_factor_percent(torque, rated_torque: float) -> float:
    """001 eq. (40): TRF = (T_max - T_min) / T_rated * 100 %."""
    torque = np.asarray(torque, float)
    return float((np.max(torque) - np.min(torque)) / rated_torque * 100.0)


def ripple(x) -> dict:
    """Peak-to-peak and RMS deviation about the mean of a steady-state signal."""
    x = np.asarray(x, float)
    return {'mean': float(np.mean(x)), 'peak_to_peak': float(np.ptp(x)),
            'rms_deviation': float(np.sqrt(np.mean((x - x.mean()) ** 2)))}


def power_factor(t, v, i, f1: float) -> float:
    """PF = mean(v i) / (V_rms I_rms) over whole periods of the line frequency f1."""
    t, v, i = (np.asarray(a, float) for a in (t, v, i))
    t0, t1 = whole_periods(t, f1)
    grid = np.linspace(t0, t1, max(len(t), 1000), endpoint=False)
    vg, ig = np.interp(grid, t, v), np.interp(grid, t, i)
    return float(np.mean(vg * ig) / (np.sqrt(np.mean(vg ** 2)) * np.sqrt(np.mean(ig ** 2))))


def rise_time(t, y, t_step: float, y_before: float, y_after: float,
              low: float = 0.1, high: float = 0.9) -> float:
    """s from the first crossing of y_before + low*dy to that of y_before + high*dy after t_step (NaN if never)."""
    t, y = np.asarray(t, float), np.asarray(y, float)
    after = t >= t_step
    t, y = t[after], y[after]
    dy = y_after - y_before
    progress = (y - y_before) / dy if dy else np.zeros_like(y)
    lo = np.nonzero(progress >= low)[0]
    hi = np.nonzero(progress >= high)[0]
    if not len(lo) or not len(hi):
        return float('nan')
    return float(t[hi[0]] - t[lo[0]])


def largest_step(t, reference) -> tuple[float, float, float] | None:
    """(t_step, before, after) of the largest jump of a piecewise-constant reference, or None."""
    reference = np.asarray(reference, float)
    if len(reference) < 2:
        return None
    jumps = np.abs(np.diff(reference))
    jumps[np.isnan(jumps)] = 0.0
    k = int(np.argmax(jumps))
    if jumps[k] == 0:
        return None
    return float(np.asarray(t)[k + 1]), float(reference[k]), float(reference[k + 1])


def current_balance(fundamentals) -> dict:
    """Fundamental amplitude per phase and the imbalance (max - min) / mean * 100 %."""
    f = np.asarray(fundamentals, float)
    return {'fundamental_amplitudes': [float(a) for a in f],
            'imbalance_percent': float((f.max() - f.min()) / f.mean() * 100.0)}


def wrap_angle(a):
    """Angle(s) wrapped to [-pi, pi)."""
    return (np.asarray(a, float) + np.pi) % (2 * np.pi) - np.pi


def error_stats(estimate, truth, angle: bool = False) -> dict:
    """Mean, RMS and max |error| of estimate - truth (angles wrapped), NaN samples skipped."""
    err = np.asarray(estimate, float) - np.asarray(truth, float)
    if angle:
        err = wrap_angle(err)
    err = err[~np.isnan(err)]
    if not len(err):
        return {'mean': float('nan'), 'rms': float('nan'), 'max_abs': float('nan'), 'samples': 0}
    return {'mean': float(np.mean(err)), 'rms': float(np.sqrt(np.mean(err ** 2))),
            'max_abs': float(np.max(np.abs(err))), 'samples': int(len(err))}
