"""Grid-side quality figures of a PFC run (pure numpy; 000 ch. III, Figs. 3.4-3.6).

Line voltage v(t) [V] and current i(t) [A] sampled over a whole number of line cycles
(:func:`whole_cycles` trims a record); RMS, P, S, PF, harmonics, THD (h = 2..40) and displacement
factor as defined in :mod:`drive_common.signals`. DC ripple: peak-to-peak, mean and pp / mean in %.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drive_common import signals


def whole_cycles(x, sample_rate: float, line_frequency: float, max_cycles: int | None = None):
    """The last samples of x spanning the largest whole number of cycles with an integer sample count."""
    x = np.asarray(x, dtype=float)
    n, _ = signals.samples_per_whole_periods(len(x), sample_rate / line_frequency, max_cycles)
    return x[len(x) - n:]


@dataclass(frozen=True)
class GridMetrics:
    """Line-side figures of one record (SI units, ratios not %)."""

    voltage_rms: float          # V
    current_rms: float          # A
    real_power: float           # W
    apparent_power: float       # VA
    power_factor: float         # 1
    displacement_factor: float  # 1
    current_thd: float          # 1
    voltage_thd: float          # 1
    current_harmonics: tuple    # A, peak amplitude of harmonics 0..H


def analyze(v, i, sample_rate: float, line_frequency: float, max_harmonic: int = 40) -> GridMetrics:
    """All line-side metrics of a record spanning whole cycles (ValueError otherwise)."""
    v = np.asarray(v, dtype=float)
    i = np.asarray(i, dtype=float)
    if v.shape != i.shape:
        raise ValueError('voltage and current records differ in length')
    m = signals.periods_in(len(v), sample_rate / line_frequency)
    v_rms, i_rms = signals.rms(v), signals.rms(i)
    i_h = np.abs(signals.harmonics(i, m, max_harmonic))
    return GridMetrics(v_rms, i_rms, float(np.mean(v * i)), v_rms * i_rms, signals.power_factor(v, i),
                       signals.displacement_factor(v, i, m), signals.thd(i, m, max_harmonic),
                       signals.thd(v, m, max_harmonic), tuple(i_h))


@dataclass(frozen=True)
class DcRipple:
    """Output (DC-link) voltage ripple."""

    mean: float            # V
    peak_to_peak: float    # V
    percent: float         # %, peak_to_peak / mean * 100


def dc_ripple(v_dc) -> DcRipple:
    """Peak-to-peak ripple of a DC voltage record (take whole line cycles)."""
    v = np.asarray(v_dc, dtype=float)
    mean = float(np.mean(v))
    pp = float(np.ptp(v))
    return DcRipple(mean, pp, 100.0 * pp / mean if mean != 0.0 else math.inf)
