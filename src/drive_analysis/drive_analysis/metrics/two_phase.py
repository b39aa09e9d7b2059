"""Metrics of the two-phase BLDC DTC results (000 ch. II and IV), pure numpy.

The contract: :mod:`drive_analysis.metrics`; rated torque ``RATED_TORQUE_000`` (000 App. A);
definitions: docs/reference/metrics.md "Two-phase BLDC DTC"; torque ripple:
:mod:`drive_analysis.metrics.ripple`.
"""
from __future__ import annotations

import math

import numpy as np

from drive_analysis.arrays import (Arrays, field, largest_step, mean_or_nan, paired,
                                   response_time, samples_in)
from drive_common import signals

from . import RATED_TORQUE_000

PROTECTION_MOTOR_OVER_CURRENT = 1


def _rms_error_pct_rated(arrays: Arrays, value: str, reference: str, t_start, t_end, rated_torque: float) -> float:
    """RMS of paired value - reference, % of rated torque (NaN without samples)."""
    d = paired(arrays, t_start, t_end)
    return 100.0 * signals.rms(d[value] - d[reference]) / rated_torque if len(d) else math.nan


def torque_estimation_rms_error_pct_rated(arrays: Arrays, t_start=None, t_end=None,
                                          rated_torque: float = RATED_TORQUE_000) -> float:
    return _rms_error_pct_rated(arrays, 'dtc.torque_estimate', 'plant.electromagnetic_torque', t_start, t_end,
                                rated_torque)


def mean_torque_N_m(arrays: Arrays, t_start=None, t_end=None) -> float:
    d = paired(arrays, t_start, t_end)
    return float(np.mean(d['plant.electromagnetic_torque'])) if len(d) else math.nan


def torque_tracking_rms_error_pct_rated(arrays: Arrays, t_start=None, t_end=None,
                                        rated_torque: float = RATED_TORQUE_000) -> float:
    return _rms_error_pct_rated(arrays, 'plant.electromagnetic_torque', 'dtc.torque_reference', t_start, t_end,
                                rated_torque)


def rise_time_s(arrays: Arrays, t_start=None, t_end=None, fraction: float = 0.9,
                signal: str = 'plant.electromagnetic_torque', smoothing: float = 0.0) -> float:
    d = paired(arrays, t_start, t_end)
    step = largest_step(d['dtc.torque_reference'])
    if step is None:
        return math.nan
    y = d[signal]
    if smoothing > 0.0:
        n = samples_in(d['time'], smoothing)
        c = np.cumsum(np.concatenate(([0.0], y)))
        lo = np.maximum(np.arange(len(y)) + 1 - n, 0)
        y = (c[1:] - c[lo]) / (np.arange(len(y)) + 1 - lo)
    return response_time(d['time'], y, *step, high=fraction)


def _phase_c_rms(arrays: Arrays, sectors, t_start, t_end) -> float:
    d = paired(arrays, t_start, t_end)
    sel = np.isin(d['dtc.sector'].astype(int), sectors)
    if not sel.any():
        return math.nan
    i_c = d['plant.phase_current'][sel, 2]
    return signals.rms(i_c)


def phase_c_current_rms_sectors_2_5_A(arrays: Arrays, t_start=None, t_end=None) -> float:
    return _phase_c_rms(arrays, (2, 5), t_start, t_end)


def phase_c_current_rms_other_sectors_A(arrays: Arrays, t_start=None, t_end=None) -> float:
    return _phase_c_rms(arrays, (1, 3, 4, 6), t_start, t_end)


def peak_phase_current_A(arrays: Arrays, t_start=None, t_end=None) -> float:
    _, i = field(arrays, 'phase_current', t_start, t_end)
    return float(np.max(np.abs(i))) if i.size else math.nan


def protection_tripped(arrays: Arrays, t_start=None, t_end=None, bit: int = PROTECTION_MOTOR_OVER_CURRENT) -> float:
    prot = field(arrays, 'protection', t_start, t_end)[1].astype(np.int64)
    return float(bool(np.any(prot & int(bit))))


def trip_time_s(arrays: Arrays, t_start=None, t_end=None, bit: int = PROTECTION_MOTOR_OVER_CURRENT) -> float:
    t, prot = field(arrays, 'protection', t_start, t_end)
    hit = np.flatnonzero(prot.astype(np.int64) & int(bit))
    return float(t[hit[0]]) if hit.size else math.nan


def mean_speed_rad_s(arrays: Arrays, t_start=None, t_end=None) -> float:
    return mean_or_nan(field(arrays, 'mechanical_speed', t_start, t_end)[1])


def flux_dip_depth_Wb(arrays: Arrays, t_start=None, t_end=None) -> float:
    d = paired(arrays, t_start, t_end)
    sector = d['dtc.sector'].astype(int)
    psi = d['dtc.flux_magnitude']
    edges = np.flatnonzero(np.diff(sector)) + 1
    depths = [float(psi[a:b].max() - psi[a:b].min()) for a, b in zip(edges[:-1], edges[1:]) if b - a > 2]
    return float(np.median(depths)) if depths else math.nan


def flux_dip_depth_ratio(arrays: Arrays, unloaded=(None, None), loaded=(None, None)) -> float:
    base = flux_dip_depth_Wb(arrays, *unloaded)
    return float(flux_dip_depth_Wb(arrays, *loaded) / base) if base > 0.0 else math.nan

