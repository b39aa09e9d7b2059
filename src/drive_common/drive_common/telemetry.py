"""Telemetry rates without rclpy: block-size limits, the telemetry parameters, live-topic decimation
(docs/architecture.md "Telemetry: blocks and live topics")."""
from __future__ import annotations

from drive_common.parameters import ParameterSpec

DEFAULT_BLOCK_SIZE = 80
"""Samples per block: 2 ms of samples at a 25 us sample period. benchmarks/bench_blocks.py: the
publishers' CPU per sample falls from 47 us (N = 10) to 26 (40) and 20 (80), then barely (160: 19)."""

MAX_BLOCK_SIZE = 10_000
"""Largest block: ~3 MB of PlantState samples, well inside one DDS sample and a bag chunk."""

DEFAULT_LIVE_PERIOD = 1e-3
"""s of sim time between the samples of a decimated live per-sample topic (1 kHz)."""

TELEMETRY_PARAMETERS = (
    ParameterSpec('telemetry.block_size', DEFAULT_BLOCK_SIZE,
                  'samples per telemetry block message (full-rate topics for bags and analysis)',
                  min_value=1, max_value=MAX_BLOCK_SIZE, runtime=False),
    ParameterSpec('telemetry.live_period', DEFAULT_LIVE_PERIOD,
                  'sim time between samples on the per-sample live topics; 0 = every sample',
                  unit='s', min_value=0.0, max_value=1.0),
)
"""Parameters of every node that publishes telemetry (add them to the node's schema)."""


def check_block_size(size) -> int:
    """size as an int if 1 <= size <= MAX_BLOCK_SIZE, else ValueError with the reason."""
    if isinstance(size, bool) or not isinstance(size, int):
        raise ValueError(f'block size must be an integer, got {size!r}')
    if not 1 <= size <= MAX_BLOCK_SIZE:
        raise ValueError(f'block size must be in [1, {MAX_BLOCK_SIZE}] samples, got {size}')
    return size


def nanoseconds(seconds: float) -> int:
    """Sim time in integer ns, rounded as the header stamps are (conversions.time_msg)."""
    return int(round(seconds * 1e9))


class Decimator:
    """Which samples a decimated live topic publishes: the first at or after each sim time
    j * period (period 0: every sample); sim time going backwards restarts the grid."""

    def __init__(self, period: float) -> None:
        if not period >= 0.0:   # also refuses NaN
            raise ValueError(f'live period must be >= 0 s, got {period!r}')
        self.period_ns = nanoseconds(period)
        self._next_ns = 0
        self._last_ns = -1

    def keep(self, stamp_ns: int) -> bool:
        """True if the sample stamped stamp_ns (sim time, ns) goes out on the live topic."""
        if stamp_ns < self._last_ns:
            self._next_ns = 0
        self._last_ns = stamp_ns
        if stamp_ns < self._next_ns:
            return False
        period = self.period_ns
        if period:
            self._next_ns = (stamp_ns // period + 1) * period
        return True
