"""Metrics of the three-phase DTC results (000 ch. V, 001 Tables IX-X), pure numpy.

The contract: :mod:`drive_analysis.metrics`; definitions: docs/reference/metrics.md
"Three-phase DTC"; torque ripple: :mod:`drive_analysis.metrics.ripple`.
"""
from __future__ import annotations

import math

import numpy as np

from drive_analysis.arrays import Arrays, field, last_whole_periods, mean_or_nan, paired
from drive_common import signals

_PHASES = {'a': 0, 'b': 1, 'c': 2}


# ---------------------------------------------------------------------------- 000 ch. V
def _angle_error(arrays: Arrays, t_start, t_end) -> np.ndarray:
    """Estimated minus true electrical rotor angle [rad], wrapped to (-pi, pi]."""
    d = paired(arrays, t_start, t_end)
    return signals.wrap_to_pi(d['dtc.rotor_angle_estimate'] - d['plant.rotor_angle'])


def angle_error_rms_deg(arrays: Arrays, t_start=None, t_end=None) -> float:
    """RMS of the estimated minus the true electrical rotor angle [deg] (000 Fig. 5.8)."""
    err = _angle_error(arrays, t_start, t_end)
    return float(np.degrees(signals.rms(err))) if len(err) else math.nan


def angle_error_max_deg(arrays: Arrays, t_start=None, t_end=None) -> float:
    """Largest |estimated - true electrical rotor angle| [deg]."""
    err = _angle_error(arrays, t_start, t_end)
    return float(np.degrees(np.max(np.abs(err)))) if len(err) else math.nan


def _d_current(arrays: Arrays, t_start, t_end, source: str) -> tuple[np.ndarray, np.ndarray]:
    d = paired(arrays, t_start, t_end)
    ref = d.get('dtc.d_current_reference', np.zeros(len(d)))
    if source == 'controller':
        return d['dtc.d_current'], ref
    if source != 'plant':
        raise ValueError(f"source must be 'controller' or 'plant', not {source!r}")
    i_al, i_be = signals.clarke_rows(d['plant.phase_current'])
    th = d['plant.rotor_angle']
    return signals.park(i_al, i_be, th)[0], ref


def d_current_mean_A(arrays: Arrays, t_start=None, t_end=None, source: str = 'controller') -> float:
    """Mean d-axis current [A] (000 Fig. 5.11: oscillates around i_d* = 0)."""
    i_d, _ = _d_current(arrays, t_start, t_end, source)
    return mean_or_nan(i_d)


def d_current_positive_fraction(arrays: Arrays, t_start=None, t_end=None, source: str = 'controller') -> float:
    """Fraction of samples with i_d above its reference i_d* (0.5 = symmetric oscillation)."""
    i_d, ref = _d_current(arrays, t_start, t_end, source)
    return float(np.mean(i_d > ref)) if len(i_d) else math.nan


def q_current_mean_A(arrays: Arrays, t_start=None, t_end=None) -> float:
    """Mean of the controller's q-axis current [A]."""
    return mean_or_nan(paired(arrays, t_start, t_end)['dtc.q_current'])


def estimated_torque_mean_N_m(arrays: Arrays, t_start=None, t_end=None) -> float:
    """Mean of the controller's torque estimate [N m] (001 Table X 'predicted torque')."""
    return mean_or_nan(paired(arrays, t_start, t_end)['dtc.torque_estimate'])


def torque_tracking_error_N_m(arrays: Arrays, t_start=None, t_end=None) -> float:
    """Mean of (T_true - T*) [N m]."""
    d = paired(arrays, t_start, t_end)
    return mean_or_nan(d['plant.electromagnetic_torque'] - d['dtc.torque_reference'])


def speed_estimate_error_pct(arrays: Arrays, t_start=None, t_end=None, pole_pairs: int = 2) -> float:
    """100 * (mean estimated electrical speed / (p * mean true mechanical speed) - 1)."""
    d = paired(arrays, t_start, t_end)
    true = mean_or_nan(d['plant.mechanical_speed']) * pole_pairs
    if not len(d) or true == 0.0:
        return math.nan
    return float(100.0 * (mean_or_nan(d['dtc.speed_estimate']) / true - 1.0))


def _flux(arrays: Arrays, t_start, t_end, source: str) -> tuple[np.ndarray, np.ndarray]:
    if source == 'controller':
        d = paired(arrays, t_start, t_end)
        return d['dtc.flux_alpha'], d['dtc.flux_beta']
    if source != 'plant':
        raise ValueError(f"source must be 'controller' or 'plant', not {source!r}")
    _, psi = field(arrays, 'flux_linkage', t_start, t_end)
    return signals.clarke_rows(psi)


def _radius_profile(arrays: Arrays, t_start, t_end, source: str, bins: int) -> np.ndarray:
    """Mean locus radius in each of ``bins`` flux-angle bins (NaN where a bin is empty)."""
    al, be = _flux(arrays, t_start, t_end, source)
    if not len(al):
        return np.full(bins, np.nan)
    r = np.hypot(al, be)
    k = np.floor((np.arctan2(be, al) % (2.0 * np.pi)) / (2.0 * np.pi) * bins).astype(int) % bins
    counts = np.bincount(k, minlength=bins)
    sums = np.bincount(k, weights=r, minlength=bins)
    with np.errstate(invalid='ignore', divide='ignore'):
        return np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)


def flux_locus_mean_radius_Wb(arrays: Arrays, t_start=None, t_end=None, source: str = 'controller',
                              bins: int = 72) -> float:
    """Mean stator-flux locus radius [Wb], averaged per angle bin (000 Figs. 5.5-5.6)."""
    prof = _radius_profile(arrays, t_start, t_end, source, bins)
    return float(np.nanmean(prof)) if np.isfinite(prof).any() else math.nan


def flux_locus_radius_variation(arrays: Arrays, t_start=None, t_end=None, source: str = 'controller',
                                bins: int = 72) -> float:
    """(max - min) / mean of the binned locus radius: 0 for a circle (000 Fig. 5.5 shape)."""
    prof = _radius_profile(arrays, t_start, t_end, source, bins)
    if not np.isfinite(prof).all():
        return math.nan
    return float((prof.max() - prof.min()) / prof.mean())


def flux_locus_dominant_order(arrays: Arrays, t_start=None, t_end=None, source: str = 'controller',
                              bins: int = 72) -> float:
    """Harmonic order (per turn) of the largest non-DC component of the binned radius profile.

    12 for the dodecagon of a 120-degree trapezoidal back-EMF machine (000 Fig. 5.5), 6 for a
    hexagon; an estimator offset shows as order 1.
    """
    prof = _radius_profile(arrays, t_start, t_end, source, bins)
    if not np.isfinite(prof).all():
        return math.nan
    spec = np.abs(np.fft.rfft(prof - prof.mean()))
    return float(np.argmax(spec[1:]) + 1)


def flux_locus_shape_correlation(arrays: Arrays, a=(None, None), b=(None, None), source: str = 'controller',
                                 bins: int = 72) -> float:
    """Correlation of the binned radius profiles of windows a and b (1 = same shape, 000 Fig. 5.6)."""
    pa = _radius_profile(arrays, a[0], a[1], source, bins)
    pb = _radius_profile(arrays, b[0], b[1], source, bins)
    ok = np.isfinite(pa) & np.isfinite(pb)
    if ok.sum() < 3:
        return math.nan
    return float(np.corrcoef(pa[ok], pb[ok])[0, 1])


def flux_locus_radius_ratio(arrays: Arrays, a=(None, None), b=(None, None), source: str = 'controller',
                            bins: int = 72) -> float:
    """Mean binned locus radius of window b / of window a (< 1: the locus shrank)."""
    ra = flux_locus_mean_radius_Wb(arrays, a[0], a[1], source, bins)
    rb = flux_locus_mean_radius_Wb(arrays, b[0], b[1], source, bins)
    return float(rb / ra) if ra > 0.0 else math.nan


# ---------------------------------------------------------------------------- 001 Tables IX-X
def _phase_spectrum(arrays: Arrays, phase, t_start, t_end, frequency, pole_pairs):
    """|X_n| peak amplitudes (n = 0, 1, 2, ... of the electrical frequency) of one true phase current."""
    t, cur, periods = last_whole_periods(arrays, 'phase_current', t_start, t_end, frequency, pole_pairs)
    if not periods:
        return None
    x = np.asarray(cur, dtype=float).reshape(-1, 3)[:, _PHASES[phase] if isinstance(phase, str) else int(phase)]
    return np.abs(signals.harmonics(x, periods, len(x) // 2 // periods))


def phase_current_fundamental_A(arrays: Arrays, phase: str = 'a', t_start=None, t_end=None,
                                frequency: float | None = None, pole_pairs: int = 1) -> float:
    """Peak fundamental amplitude [A] of one true phase current (001 Table IX)."""
    spec = _phase_spectrum(arrays, phase, t_start, t_end, frequency, pole_pairs)
    return float(spec[1]) if spec is not None and len(spec) > 1 else math.nan


def _fundamental_of(phase: str):
    """phase_current_fundamental_A of one phase, as a metric of its own name."""
    def metric(arrays: Arrays, **options) -> float:
        return phase_current_fundamental_A(arrays, phase, **options)
    metric.__doc__ = f'phase_current_fundamental_A of phase {phase}.'
    return metric


phase_a_current_fundamental_A = _fundamental_of('a')
phase_b_current_fundamental_A = _fundamental_of('b')
phase_c_current_fundamental_A = _fundamental_of('c')


def current_imbalance(arrays: Arrays, t_start=None, t_end=None, frequency: float | None = None,
                      pole_pairs: int = 1) -> float:
    """(max - min) / mean of the three fundamental phase-current amplitudes."""
    amps = [phase_current_fundamental_A(arrays, p, t_start, t_end, frequency, pole_pairs) for p in 'abc']
    if not all(math.isfinite(a) for a in amps) or np.mean(amps) <= 0.0:
        return math.nan
    return float((max(amps) - min(amps)) / np.mean(amps))


def phase_current_thd_percent(arrays: Arrays, phase: str = 'a', t_start=None, t_end=None,
                              frequency: float | None = None, pole_pairs: int = 1, max_order: int = 50) -> float:
    """THD_x of one phase, 001 eq. (39) [%] (integer harmonics 2..max_order)."""
    spec = _phase_spectrum(arrays, phase, t_start, t_end, frequency, pole_pairs)
    if spec is None or len(spec) < 3 or spec[1] <= 0.0:
        return math.nan
    return 100.0 * signals.thd_of(spec[:max_order + 1])


def current_thd_percent(arrays: Arrays, t_start=None, t_end=None, frequency: float | None = None,
                        pole_pairs: int = 1, max_order: int = 50) -> float:
    """Total harmonic distortion of the three phase currents, 001 eq. (39) [%]."""
    thd = [phase_current_thd_percent(arrays, p, t_start, t_end, frequency, pole_pairs, max_order) for p in 'abc']
    return signals.total_thd(thd)


def predicted_minus_actual_torque_pct(arrays: Arrays, t_start=None, t_end=None) -> float:
    """100 * (mean predicted - mean actual torque) / mean actual torque (001 Table X offset)."""
    d = paired(arrays, t_start, t_end)
    actual = mean_or_nan(d['plant.electromagnetic_torque'])
    if not len(d) or actual == 0.0:
        return math.nan
    return float(100.0 * (mean_or_nan(d['dtc.torque_estimate']) - actual) / actual)

