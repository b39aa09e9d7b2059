"""Input-voltage feed-forward of 000 ch. III: line-period average (3.2) and C (3.3)-(3.5).

:class:`LinePeriodAverage` averages the per-unit rectified voltage A over exactly one line period
T = 1/f: T/T_s is rarely an integer (80 kHz / 60 Hz = 1333.3), so the window holds floor(T/T_s)
samples plus the fractional weight of the one before (a periodic signal then averages without
ripple); before one period it is the mean so far. :func:`feedforward_c` is eq. (3.5) with V_dc(pu)
clamped to the design range [2/(pi K_m), 2/pi], so C stays in [1/K_m^2, 1].
"""
from __future__ import annotations

import math

import numpy as np

from drive_common.compiled import libm_pow, njit


# Running state of a line-period average (float64 array): ring index, samples seen, window sum.
AVG_INDEX, AVG_COUNT, AVG_SUM = 0, 1, 2


@njit
def average_update(buf, st, n: int, frac: float, value: float) -> float:
    """Add value to the ring buf (n + 1 slots, state st); return the mean over the last line period."""
    size = n + 1
    i = int(st[AVG_INDEX])
    count = int(st[AVG_COUNT])
    # The slot being overwritten held the sample n+1 back; the one n back leaves the sum.
    leaving = buf[(i + 1) % size] if count >= n else 0.0
    buf[i] = value
    st[AVG_SUM] += value - leaving
    st[AVG_INDEX] = (i + 1) % size
    count += 1
    st[AVG_COUNT] = count
    if count <= n:
        return st[AVG_SUM] / count
    older = buf[(i + 1) % size]  # now the sample n+1 back
    return (st[AVG_SUM] + frac * older) / (n + frac)


def line_period_window(line_frequency: float, sample_period: float) -> tuple[int, float]:
    """(whole samples n, fractional weight) of one line period; ValueError if it cannot be averaged."""
    if line_frequency <= 0.0 or sample_period <= 0.0:
        raise ValueError('line_frequency and sample_period must be positive')
    window = 1.0 / (line_frequency * sample_period)  # samples per line period
    n = int(math.floor(window + 1e-9))
    if n < 2:
        raise ValueError('sample_period must be well below the line period')
    frac = window - n
    return n, (frac if frac > 1e-9 else 0.0)


class LinePeriodAverage:
    """Running mean of a sampled signal over one line period (O(1) per sample): n whole samples and
    the weight frac of the one before; state in float64 arrays that compiled kernels update in place."""

    __slots__ = ('buffer', 'state', 'n', 'frac')

    def __init__(self, line_frequency: float, sample_period: float) -> None:
        self.n, self.frac = line_period_window(line_frequency, sample_period)
        self.buffer = np.zeros(self.n + 1)  # ring: the last n samples plus the one before
        self.state = np.zeros(3)

    @property
    def window(self) -> float:
        """Window length in samples (T / T_s)."""
        return self.n + self.frac

    def update(self, value: float) -> float:
        """Add one sample; return the average over the last line period."""
        return float(average_update(self.buffer, self.state, self.n, self.frac, float(value)))


@njit
def feedforward_c(vdc_pu: float, km: float) -> float:
    """Eq. (3.5): C = V_inv(pu)^2 = 4 / (pi * V_dc(pu) * K_m)^2, V_dc(pu) clamped to the design range."""
    lo = 2.0 / (math.pi * km)
    hi = 2.0 / math.pi
    v = min(max(vdc_pu, lo), hi)
    return 4.0 / libm_pow(math.pi * v * km, 2.0)   # CPython's float ** 2 (libm pow)
