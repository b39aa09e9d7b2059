"""Signal maths shared by the cores and the analysis (pure Python / numpy, no ROS).

Frames: amplitude-invariant Clarke (000 eq. (1.21) scaled by 2/3) and Park
(docs/architecture.md "Conventions"). Spectrum of a record of m whole periods (000 ch. III,
001 eq. (39)): harmonic h is DFT bin h*m, peak amplitudes, THD as a ratio.
"""
from __future__ import annotations

import math

import numpy as np

TWO_PI = 2.0 * math.pi
SQRT3 = math.sqrt(3.0)
INV_SQRT3 = 1.0 / SQRT3
PHASE_SHIFT = (0.0, TWO_PI / 3.0, 2.0 * TWO_PI / 3.0)
"""rad: phase x quantities are functions of theta_e - PHASE_SHIFT[x] (a, b, c)."""

__all__ = ['TWO_PI', 'SQRT3', 'INV_SQRT3', 'PHASE_SHIFT', 'clarke', 'clarke_rows', 'inverse_clarke',
           'park', 'inverse_park', 'wrap_angle', 'wrap_to_pi', 'rms', 'samples_per_whole_periods', 'periods_in',
           'harmonics', 'thd_of', 'thd', 'total_thd', 'power_factor', 'displacement_factor']


# ---------------------------------------------------------------------------- frames
def clarke(x_a, x_b, x_c):
    """(alpha, beta) of a three-phase set (amplitude-invariant; zero sequence dropped)."""
    return (2.0 * x_a - x_b - x_c) / 3.0, (x_b - x_c) * INV_SQRT3


def clarke_rows(abc) -> tuple[np.ndarray, np.ndarray]:
    """:func:`clarke` of an (N, 3) array of phase samples."""
    abc = np.asarray(abc, dtype=float).reshape(-1, 3)
    return clarke(abc[:, 0], abc[:, 1], abc[:, 2])


def inverse_clarke(x_alpha: float, x_beta: float) -> tuple[float, float, float]:
    """(a, b, c) of an alpha/beta pair with zero zero-sequence."""
    h = 0.5 * SQRT3 * x_beta
    return x_alpha, -0.5 * x_alpha + h, -0.5 * x_alpha - h


def park(x_alpha, x_beta, theta):
    """(d, q) in the frame at electrical angle theta [rad] (floats or numpy arrays)."""
    if isinstance(theta, float):
        c, s = math.cos(theta), math.sin(theta)
    else:
        c, s = np.cos(theta), np.sin(theta)
    return x_alpha * c + x_beta * s, -x_alpha * s + x_beta * c


def inverse_park(x_d: float, x_q: float, theta: float) -> tuple[float, float]:
    """(alpha, beta) of a d/q pair in the frame at theta [rad]."""
    c = math.cos(theta)
    s = math.sin(theta)
    return x_d * c - x_q * s, x_d * s + x_q * c


def wrap_angle(theta: float) -> float:
    """theta wrapped to [0, 2 pi) rad (scalar)."""
    theta = math.fmod(theta, TWO_PI)
    if theta < 0.0:
        theta += TWO_PI
    if theta >= TWO_PI:  # fmod of a tiny negative number
        theta = 0.0
    return theta


def wrap_to_pi(theta) -> np.ndarray:
    """Angle difference(s) wrapped to [-pi, pi) rad (numpy)."""
    return (np.asarray(theta, dtype=float) + math.pi) % TWO_PI - math.pi


# ---------------------------------------------------------------------------- spectrum
def rms(x) -> float:
    """Root-mean-square of a sampled signal (same unit as x)."""
    x = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(x * x)))


def samples_per_whole_periods(n_samples: int, samples_per_period: float,
                              max_periods: int | None = None) -> tuple[int, int]:
    """(n, m): the largest m (<= max_periods) whole periods spanning an integer n <= n_samples samples.

    ValueError when not even one period fits with an integer sample count.
    """
    # A period from a measured step is a hair off: exactly m periods may come out as m - 1e-12.
    m = int((n_samples + 1e-6) / samples_per_period)
    if max_periods is not None:
        m = min(m, max_periods)
    while m >= 1:
        n = m * samples_per_period
        if abs(n - round(n)) < 1e-6 and round(n) <= n_samples:
            return int(round(n)), m
        m -= 1
    raise ValueError(f'{n_samples} samples hold no whole number of periods of '
                     f'{samples_per_period:.6g} samples with an integer sample count')


def periods_in(n_samples: int, samples_per_period: float) -> int:
    """Number of whole periods n samples span; ValueError unless it is (close to) an integer."""
    periods = n_samples / samples_per_period
    m = int(round(periods))
    if m < 1 or abs(periods - m) > 1e-6 * max(periods, 1.0):
        raise ValueError(f'{n_samples} samples span {periods:.6f} periods of {samples_per_period:.6g} '
                         'samples; need a whole number')
    return m


def harmonics(x, periods: int, max_harmonic: int) -> np.ndarray:
    """Complex peak-amplitude phasors X_0..X_H of a record spanning exactly ``periods`` periods.

    X_0 is the mean. Orders above the record's Nyquist limit are left out.
    """
    x = np.asarray(x, dtype=float)
    spectrum = np.fft.rfft(x) / len(x)
    bins = np.arange(max_harmonic + 1) * int(periods)
    out = 2.0 * spectrum[bins[bins < len(spectrum)]]
    out[0] = spectrum[0]
    return out


def thd_of(amplitudes) -> float:
    """THD (ratio) of peak amplitudes X_0..X_H: sqrt(sum_{h=2..H} X_h^2) / X_1 (001 eq. (39))."""
    h = np.asarray(amplitudes, dtype=float)
    if len(h) < 2 or h[1] == 0.0:
        raise ValueError('no fundamental component')
    return float(np.sqrt(np.sum(h[2:] ** 2)) / h[1])


def thd(x, periods: int, max_harmonic: int) -> float:
    """THD (ratio) of a record spanning ``periods`` whole periods, harmonics 2..max_harmonic."""
    return thd_of(np.abs(harmonics(x, periods, max_harmonic)))


def total_thd(phase_thds) -> float:
    """THD of a three-phase set from the phase THDs, 001 eq. (39): sqrt((THD_a^2 + THD_b^2 + THD_c^2) / 3)."""
    return float(np.sqrt(np.mean(np.square(np.asarray(phase_thds, dtype=float)))))


def power_factor(v, i) -> float:
    """PF = mean(v i) / (V_rms I_rms) over the samples given (whole periods; 0 if either is zero)."""
    v = np.asarray(v, dtype=float)
    i = np.asarray(i, dtype=float)
    s = rms(v) * rms(i)
    return float(np.mean(v * i) / s) if s > 0.0 else 0.0


def displacement_factor(v, i, periods: int) -> float:
    """cos of the phase between the voltage and current fundamentals (records of whole periods)."""
    v1 = harmonics(v, periods, 1)[1]
    i1 = harmonics(i, periods, 1)[1]
    return float(math.cos(np.angle(v1) - np.angle(i1)))
