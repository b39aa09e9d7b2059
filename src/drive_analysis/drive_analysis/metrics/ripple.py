"""Torque ripple metrics (000 ch. II / IV and 001 eq. (40)), pure numpy.

The contract: :mod:`drive_analysis.metrics`. Switching (high-frequency) and commutation
(low-frequency) ripple, and 001's torque ripple factor over the median electrical period;
definitions: docs/reference/metrics.md "Torque ripple".
"""
from __future__ import annotations

import math

import numpy as np

from drive_analysis.arrays import Arrays, last_whole_periods, moving_average, paired, samples_in

from . import RATED_TORQUE_000, RATED_TORQUE_001


def _torque_and_moving_average(arrays: Arrays, t_start, t_end, window: float):
    """(T_true, its moving average over ``window`` [s], samples per window), or None if too short."""
    d = paired(arrays, t_start, t_end)
    te = d['plant.electromagnetic_torque']
    n = samples_in(d['time'], window)
    if len(te) <= n:
        return None
    return te, moving_average(te, n), n


def high_frequency_torque_ripple_pct_rated(arrays: Arrays, t_start=None, t_end=None, window: float = 1e-3,
                                           rated_torque: float = RATED_TORQUE_000) -> float:
    """Switching ripple: std of T_true about its moving average, % of rated torque."""
    smoothed = _torque_and_moving_average(arrays, t_start, t_end, window)
    if smoothed is None:
        return math.nan
    te, avg, n = smoothed
    centred = te[n // 2: n // 2 + len(avg)]
    return float(100.0 * np.std(centred - avg) / rated_torque)


def low_frequency_torque_ripple_pct_rated(arrays: Arrays, t_start=None, t_end=None, window: float = 1e-3,
                                          rated_torque: float = RATED_TORQUE_000) -> float:
    """Commutation ripple: peak-to-peak of T_true's moving average, % of rated torque (000 Fig. 2.10)."""
    smoothed = _torque_and_moving_average(arrays, t_start, t_end, window)
    if smoothed is None:
        return math.nan
    avg = smoothed[1]
    return float(100.0 * (avg.max() - avg.min()) / rated_torque)


def torque_ripple_factor_median_period_percent(arrays: Arrays, t_start=None, t_end=None,
                                               rated_torque: float = RATED_TORQUE_001, signal: str = 'plant',
                                               smoothing: float = 0.0, frequency: float | None = None,
                                               pole_pairs: int = 1) -> float:
    """Torque ripple factor, 001 eq. (40): median per-period pk-pk torque / T_rated [%]."""
    if signal == 'plant':
        t, x, periods = last_whole_periods(arrays, 'electromagnetic_torque', t_start, t_end, frequency, pole_pairs)
    elif signal == 'estimate':
        d = paired(arrays, t_start, t_end)
        sub = {'plant/state.time': d['time'], 'plant/state.electromagnetic_torque': d['dtc.torque_estimate'],
               'plant/state.mechanical_speed': d['plant.mechanical_speed']}
        t, x, periods = last_whole_periods(sub, 'electromagnetic_torque', None, None, frequency, pole_pairs)
    else:
        raise ValueError(f"signal must be 'plant' or 'estimate', not {signal!r}")
    if not periods:
        return math.nan
    x = np.asarray(x, dtype=float)
    if smoothing > 0.0:
        k = max(1, int(round(smoothing / float(t[1] - t[0]))))
        x = np.convolve(x, np.ones(k) / k, mode='same')
        x[:k] = x[k]
        x[-k:] = x[-k - 1]
    per = x.reshape(periods, -1)
    return float(100.0 * np.median(per.max(axis=1) - per.min(axis=1)) / rated_torque)
