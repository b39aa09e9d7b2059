"""Grid-side quality metrics of a PFC run (pure numpy; seed 000 ch. III, Figs. 3.4-3.6).

Inputs are sampled line voltage v(t) [V] and line current i(t) [A] at a fixed
sample rate covering a whole number of line cycles (use
:func:`whole_cycles` to trim a record). Definitions:

* RMS: sqrt(mean(x^2)).
* Real power P = mean(v i); apparent power S = V_rms I_rms;
  power factor PF = P / S (includes distortion and displacement).
* Harmonic h of a record of m cycles is FFT bin h*m (no leakage for whole
  cycles). THD = sqrt(sum_{h=2..H} |X_h|^2) / |X_1| (H = 40 by default).
* Displacement factor DF = cos(angle(V_1) - angle(I_1)) of the fundamentals;
  PF = DF / sqrt(1 + THD_i^2) for a sinusoidal voltage.
* DC ripple of the output voltage: peak-to-peak, mean and pp / mean in %.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def rms(x) -> float:
    """Root-mean-square of a sampled signal (same unit as x)."""
    x = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(x * x)))


def cycles_in(n_samples: int, sample_rate: float, line_frequency: float) -> int:
    """Number of whole line cycles n samples span; ValueError unless it is (close to) an integer."""
    cycles = n_samples * line_frequency / sample_rate
    m = int(round(cycles))
    if m < 1 or abs(cycles - m) > 1e-6 * max(cycles, 1.0):
        raise ValueError(f'{n_samples} samples at {sample_rate} Hz span {cycles:.6f} line cycles of '
                         f'{line_frequency} Hz; need a whole number (see whole_cycles)')
    return m


def whole_cycles(x, sample_rate: float, line_frequency: float, max_cycles: int | None = None):
    """The last samples of x spanning the largest whole number of cycles with an integer sample count."""
    x = np.asarray(x, dtype=float)
    per_cycle = sample_rate / line_frequency
    m = int(len(x) // per_cycle) if max_cycles is None else min(max_cycles, int(len(x) // per_cycle))
    while m >= 1:
        n = m * per_cycle
        if abs(n - round(n)) < 1e-6:
            return x[len(x) - int(round(n)):]
        m -= 1
    raise ValueError('no whole number of line cycles has an integer number of samples in this record')


def harmonics(x, sample_rate: float, line_frequency: float, max_harmonic: int = 40) -> np.ndarray:
    """Complex amplitude phasors X_0..X_H (peak values; X_0 is the mean) over whole cycles."""
    x = np.asarray(x, dtype=float)
    m = cycles_in(len(x), sample_rate, line_frequency)
    spectrum = np.fft.rfft(x) / len(x)
    bins = np.arange(max_harmonic + 1) * m
    if bins[-1] >= len(spectrum):
        raise ValueError(f'sample rate too low for harmonic {max_harmonic}')
    out = 2.0 * spectrum[bins]
    out[0] = spectrum[0]
    return out


def thd(x, sample_rate: float, line_frequency: float, max_harmonic: int = 40) -> float:
    """Total harmonic distortion (ratio, not %) of x: harmonics 2..H over the fundamental."""
    h = np.abs(harmonics(x, sample_rate, line_frequency, max_harmonic))
    if h[1] == 0.0:
        raise ValueError('no fundamental component')
    return float(np.sqrt(np.sum(h[2:] ** 2)) / h[1])


def power_factor(v, i) -> float:
    """PF = mean(v i) / (V_rms I_rms) over the samples given (whole cycles)."""
    v = np.asarray(v, dtype=float)
    i = np.asarray(i, dtype=float)
    s = rms(v) * rms(i)
    return float(np.mean(v * i) / s) if s > 0.0 else 0.0


def displacement_factor(v, i, sample_rate: float, line_frequency: float) -> float:
    """cos of the phase between the voltage and current fundamentals."""
    v1 = harmonics(v, sample_rate, line_frequency, 1)[1]
    i1 = harmonics(i, sample_rate, line_frequency, 1)[1]
    return float(math.cos(np.angle(v1) - np.angle(i1)))


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
    """All line-side metrics of a record spanning whole cycles."""
    v = np.asarray(v, dtype=float)
    i = np.asarray(i, dtype=float)
    if v.shape != i.shape:
        raise ValueError('voltage and current records differ in length')
    v_rms, i_rms = rms(v), rms(i)
    p = float(np.mean(v * i))
    i_h = np.abs(harmonics(i, sample_rate, line_frequency, max_harmonic))
    return GridMetrics(v_rms, i_rms, p, v_rms * i_rms, power_factor(v, i),
                       displacement_factor(v, i, sample_rate, line_frequency),
                       thd(i, sample_rate, line_frequency, max_harmonic),
                       thd(v, sample_rate, line_frequency, max_harmonic), tuple(i_h))


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
