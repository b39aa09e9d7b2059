"""Input-voltage feed-forward of 000 ch. III: line-period average (3.2) and C (3.3)-(3.5).

:class:`LinePeriodAverage` is the moving average of the per-unit rectified
voltage A over exactly one line period T = 1/f (eq. 3.2). T/T_s is rarely an
integer (80 kHz / 60 Hz = 1333.3 samples), so the window holds the last
floor(T/T_s) samples plus the fractional weight of the one before: a
periodic signal sampled at T_s then has a ripple-free average. Before one
period has been seen it returns the mean of the samples so far.

:func:`feedforward_c` is eq. (3.5), C = 4 / (pi V_dc(pu) K_m)^2, with V_dc(pu)
clamped to the design input range [2/(pi K_m), 2/pi] (the average of a
rectified sine of peak V_min ... V_max, per unit of V_max), so C stays in
[1/K_m^2, 1] during start-up and line drop-outs.
"""
from __future__ import annotations

import math



class LinePeriodAverage:
    """Running mean of a sampled signal over one line period (O(1) per sample)."""

    __slots__ = ('_buffer', '_n', '_frac', '_index', '_count', '_sum')

    def __init__(self, line_frequency: float, sample_period: float) -> None:
        if line_frequency <= 0.0 or sample_period <= 0.0:
            raise ValueError('line_frequency and sample_period must be positive')
        window = 1.0 / (line_frequency * sample_period)  # samples per line period
        n = int(math.floor(window + 1e-9))
        if n < 2:
            raise ValueError('sample_period must be well below the line period')
        frac = window - n
        self._n = n
        self._frac = frac if frac > 1e-9 else 0.0
        self._buffer = [0.0] * (n + 1)  # ring: the last n samples plus the one before (floats)
        self._index = 0
        self._count = 0
        self._sum = 0.0   # sum of the last n samples

    @property
    def window(self) -> float:
        """Window length in samples (T / T_s)."""
        return self._n + self._frac

    def reset(self) -> None:
        self._buffer = [0.0] * (self._n + 1)
        self._index = 0
        self._count = 0
        self._sum = 0.0

    def update(self, value: float) -> float:
        """Add one sample; return the average over the last line period."""
        buf = self._buffer
        size = self._n + 1
        i = self._index
        # The slot being overwritten held the sample n+1 back; the one n back leaves the sum.
        leaving = buf[(i + 1) % size] if self._count >= self._n else 0.0
        buf[i] = value
        self._sum += value - leaving
        self._index = (i + 1) % size
        self._count += 1
        if self._count <= self._n:
            return self._sum / self._count
        older = buf[(i + 1) % size]  # now the sample n+1 back
        return (self._sum + self._frac * older) / (self._n + self._frac)


def feedforward_c(vdc_pu: float, km: float) -> float:
    """Eq. (3.5): C = V_inv(pu)^2 = 4 / (pi * V_dc(pu) * K_m)^2, V_dc(pu) clamped to the design range."""
    lo = 2.0 / (math.pi * km)
    hi = 2.0 / math.pi
    v = min(max(vdc_pu, lo), hi)
    return 4.0 / (math.pi * v * km) ** 2
