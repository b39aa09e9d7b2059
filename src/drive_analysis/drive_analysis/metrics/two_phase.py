"""Metrics of the two-phase BLDC DTC results (000 ch. II and IV), pure numpy.

Every metric takes the arrays dict of
the flat arrays dict (:mod:`drive_analysis.arrays`) -- plant ground truth
as ``'plant/state.<field>'`` (one row per recorded plant tick, the last row
is the final state) and controller internals as ``'dtc/status.<field>'``
(one row per controller sample) -- plus keyword options, and returns a
float (NaN when the window holds no data). Controller and plant rows are
paired by their ``step`` (the status of step k and the plant state at t_k).
Options ``t_start`` / ``t_end`` [s] restrict a metric to a time window
(default: the whole run); windows and pairing: :mod:`drive_analysis.arrays`.
Rated torque: ``RATED_TORQUE_000`` (000 App. A). The torque ripple metrics
are in :mod:`drive_analysis.metrics.ripple`.

Definitions (the names are the ``metric:`` keys of the scenarios' checks):

``torque_estimation_rms_error_pct_rated``
    RMS over the window of (T_est - T_true) at the controller samples, in %
    of rated torque; T_est = ``dtc/status.torque_estimate`` (eq. 2.16 / 4.1
    from the back-EMF table and the sensed currents), T_true =
    ``plant/state.electromagnetic_torque`` at the same instant t_k.
``mean_torque_N_m``
    Mean of the plant's true electromagnetic torque over the window [N m].
``rise_time_s``
    Torque response to the largest step of T* inside the window: time from
    the step (first controller sample with the new reference) to the first
    sample at which ``signal`` (default the true torque) reaches
    T*_before + ``fraction`` (default 0.9) * (T*_after - T*_before). With
    hysteresis DTC the switching ripple is comparable to the step, so a
    10-90 % definition on the raw torque is meaningless; this 0-90 %
    response time is what the seeds call "fast torque response".
    Option ``smoothing`` [s] (default 0): the signal is first replaced by its
    trailing moving average over that time, for bands so wide (four-switch,
    0.05 N m) that the raw ripple crosses the 90 % level before the step has
    acted; the average adds up to about 0.9 * smoothing to the result.
``phase_c_current_rms_sectors_2_5_A`` / ``phase_c_current_rms_other_sectors_A``
    RMS of the plant's phase-c current over the controller samples whose
    sector (``dtc/status.sector``) is II or V (four-switch: phase-torque
    control, i_c should stay near zero, 000 Fig. 4.13) / in I, III, IV, VI.
``peak_phase_current_A``
    Largest |i_x| of the true phase currents in the window [A].
``protection_tripped``
    1.0 if a plant protection of ``bit`` (PlantState PROTECTION_*: 1 = motor
    peak current, the default; 2 = boost over-current, 4 = over-voltage,
    6 = either boost protection) was set at any recorded sample in the
    window, else 0.0.
``trip_time_s``
    Sim time of the first recorded sample with a protection of ``bit`` set (NaN if none).
``mean_speed_rad_s``
    Mean mechanical speed [rad/s] over the window.
``flux_dip_depth_Wb``
    Depth of the commutation dips of the open-loop estimated stator flux
    magnitude |psi_s| (``dtc/status.flux_magnitude``): the window is cut
    into the intervals of constant sector (60 electrical degrees, one
    commutation each); per complete interval depth = max |psi_s| - min
    |psi_s|; the metric is the median over the intervals [Wb].
``flux_dip_depth_ratio``
    flux_dip_depth_Wb over the ``loaded`` window (t0, t1) divided by the
    same over the ``unloaded`` window (000 Figs. 2.4 vs 2.5: the dips
    deepen with load).
``torque_tracking_rms_error_pct_rated``
    RMS of (T_true - T*) over the window in % of rated torque (loss of
    torque control shows as a large value).
"""
from __future__ import annotations

import math

import numpy as np

from drive_analysis.arrays import (Arrays, field, largest_step, mean_or_nan, paired,
                                   response_time, samples_in)
from drive_common import signals

from . import RATED_TORQUE_000

PROTECTION_MOTOR_OVER_CURRENT = 1


def _rms_pct_rated(err: np.ndarray, rated_torque: float) -> float:
    return 100.0 * signals.rms(err) / rated_torque


def torque_estimation_rms_error_pct_rated(arrays: Arrays, t_start=None, t_end=None,
                                          rated_torque: float = RATED_TORQUE_000) -> float:
    d = paired(arrays, t_start, t_end)
    if not len(d):
        return math.nan
    return _rms_pct_rated(d['dtc.torque_estimate'] - d['plant.electromagnetic_torque'], rated_torque)


def mean_torque_N_m(arrays: Arrays, t_start=None, t_end=None) -> float:
    d = paired(arrays, t_start, t_end)
    return float(np.mean(d['plant.electromagnetic_torque'])) if len(d) else math.nan


def torque_tracking_rms_error_pct_rated(arrays: Arrays, t_start=None, t_end=None,
                                        rated_torque: float = RATED_TORQUE_000) -> float:
    d = paired(arrays, t_start, t_end)
    if not len(d):
        return math.nan
    return _rms_pct_rated(d['plant.electromagnetic_torque'] - d['dtc.torque_reference'], rated_torque)


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

