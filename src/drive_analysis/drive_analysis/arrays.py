"""The flat arrays dict every metric takes, and the helpers to slice it (numpy, no ROS).

A run is one dict, keys ``'<topic without leading slash>.<field>'`` (``'plant/state.time'`` [s],
``'plant/state.phase_current'`` [(N, 3) A], ``'dtc/status.torque_estimate'``, ...), built by the
headless runner (:meth:`drive_bringup.headless.HeadlessResult.arrays`) or from a bag
(:func:`flatten_columns` of :func:`drive_analysis.bag_columns.load_columns`). Windows:
``t_start <= t <= t_end`` (both ends included, 1e-12 s slack; None = open). Controller and plant
rows are paired by their ``step`` (the status of step k and the plant state at t_k).
"""
from __future__ import annotations

import math

import numpy as np

from drive_common import signals

Arrays = dict
PLANT, DTC = 'plant/state', 'dtc/status'


def flatten_columns(columns: dict[str, dict[str, np.ndarray]]) -> Arrays:
    """{topic: {field: array}} (:func:`~drive_analysis.bag_columns.load_columns`) -> flat arrays ('t' -> 'time')."""
    return {f'{topic.lstrip("/")}.{"time" if name == "t" else name}': values
            for topic, cols in columns.items() for name, values in cols.items()}


def columns_of(arrays: Arrays) -> dict[str, dict[str, np.ndarray]]:
    """Flat arrays -> {'/topic': {field: array}} ('time' -> 't'): the inverse of :func:`flatten_columns`."""
    columns: dict[str, dict[str, np.ndarray]] = {}
    for key, values in arrays.items():
        topic, _, name = key.rpartition('.')
        columns.setdefault(f'/{topic}', {})['t' if name == 'time' else name] = values
    return columns


def window(t, t_start: float | None = None, t_end: float | None = None) -> np.ndarray:
    """Boolean mask of the samples with t_start <= t <= t_end (None: open end)."""
    t = np.asarray(t, dtype=float)
    lo = -math.inf if t_start is None else float(t_start)
    hi = math.inf if t_end is None else float(t_end)
    return (t >= lo - 1e-12) & (t <= hi + 1e-12)


def field(arrays: Arrays, name: str, t_start=None, t_end=None, topic: str = PLANT) -> tuple[np.ndarray, np.ndarray]:
    """(t, values) of ``<topic>.<name>`` within the window."""
    t = np.asarray(arrays[f'{topic}.time'], dtype=float)
    keep = window(t, t_start, t_end)
    return t[keep], np.asarray(arrays[f'{topic}.{name}'])[keep]


class Paired:
    """Plant rows at the controller samples within a window: ``d['time']``, ``d['plant.<f>']``,
    ``d['dtc.<f>']``. The rows are matched once; a column is indexed when first asked for."""

    def __init__(self, arrays: Arrays, t_start=None, t_end=None) -> None:
        p_step = np.asarray(arrays[f'{PLANT}.step']).astype(np.int64)
        d_step = np.asarray(arrays[f'{DTC}.step']).astype(np.int64)
        order = np.argsort(p_step, kind='stable')
        pos = np.clip(np.searchsorted(p_step[order], d_step), 0, len(p_step) - 1)
        found = p_step[order][pos] == d_step
        rows_p = order[pos[found]]
        t = np.asarray(arrays[f'{PLANT}.time'])[rows_p]
        keep = window(t, t_start, t_end)
        self._arrays = arrays
        self._rows = {'plant': rows_p[keep], 'dtc': np.flatnonzero(found)[keep]}
        self._columns = {'time': t[keep]}

    def __getitem__(self, key: str) -> np.ndarray:
        if key not in self._columns:
            side, _, name = key.partition('.')
            topic = {'plant': PLANT, 'dtc': DTC}.get(side)
            if topic is None or name == 'time' or f'{topic}.{name}' not in self._arrays:
                raise KeyError(key)
            self._columns[key] = np.asarray(self._arrays[f'{topic}.{name}'])[self._rows[side]]
        return self._columns[key]

    def get(self, key: str, default=None):
        try:
            return self[key]
        except KeyError:
            return default

    def __contains__(self, key: str) -> bool:
        return self.get(key) is not None

    def __len__(self) -> int:
        return len(self._columns['time'])


paired = Paired     # paired(arrays, t_start, t_end): the metrics' spelling


def largest_step(reference) -> tuple[int, float, float] | None:
    """(index of the first sample at the new value, value before, value after) of the largest
    jump of a piecewise-constant reference; None if it never changes (NaN jumps ignored)."""
    reference = np.asarray(reference, dtype=float)
    if len(reference) < 2:
        return None
    jumps = np.abs(np.diff(reference))
    jumps[np.isnan(jumps)] = 0.0
    j = int(np.argmax(jumps))
    if jumps[j] == 0.0:
        return None
    return j + 1, float(reference[j]), float(reference[j + 1])


def _first_reaching(y: np.ndarray, before: float, after: float, fraction: float) -> int | None:
    """Index of the first sample of y at or past before + fraction (after - before), or None."""
    level = before + fraction * (after - before)
    hit = np.flatnonzero((y - level) * np.sign(after - before) >= 0.0)
    return int(hit[0]) if hit.size else None


def response_time(t, y, start: int, before: float, after: float, high: float = 0.9,
                  low: float | None = None) -> float:
    """Step response time [s] of y after a reference step at index ``start``: from the step (or,
    with ``low``, from the first sample reaching before + low dy) to the first sample reaching
    before + high dy, dy = after - before; NaN if never reached."""
    t, y = np.asarray(t, dtype=float)[start:], np.asarray(y, dtype=float)[start:]
    hi = _first_reaching(y, before, after, high)
    lo = 0 if low is None else _first_reaching(y, before, after, low)
    if hi is None or lo is None:
        return math.nan
    return float(t[hi] - t[lo])


def mean_or_nan(x) -> float:
    """Mean of x, NaN for an empty window."""
    return float(np.mean(x)) if len(x) else math.nan


def moving_average(x: np.ndarray, n: int) -> np.ndarray:
    """Means of every run of n consecutive samples (len(x) - n + 1 values; n clipped to 1..len(x))."""
    n = max(1, min(int(n), len(x)))
    c = np.cumsum(np.concatenate(([0.0], x)))
    return (c[n:] - c[:-n]) / n


def samples_in(time: np.ndarray, duration: float) -> int:
    """Samples of the record's median step that span ``duration`` [s] (at least 1)."""
    dt = float(np.median(np.diff(time))) if len(time) > 1 else 1.0
    return max(1, int(round(duration / dt)))


def last_whole_periods(arrays: Arrays, name: str, t_start=None, t_end=None, frequency: float | None = None,
                       pole_pairs: int = 1) -> tuple[np.ndarray, np.ndarray, int]:
    """(t, x, periods): plant samples of ``name`` over the most whole electrical periods ending at the window's end.

    The period is rounded to whole samples of the median step; ``frequency`` [Hz] defaults to
    the mean |mechanical speed| * ``pole_pairs`` / (2 pi). ``periods`` is 0 (and t, x empty)
    when the window holds less than one period.
    """
    t, x = field(arrays, name, t_start, t_end)
    if len(t) >= 4:
        if frequency is None:
            frequency = abs(float(np.mean(field(arrays, 'mechanical_speed', t_start, t_end)[1]))) * pole_pairs / (
                2.0 * math.pi)
        if frequency > 0.0:
            n_per = int(round(1.0 / (frequency * float(np.median(np.diff(t))))))
            if 0 < n_per <= len(t):
                n, periods = signals.samples_per_whole_periods(len(t), n_per)
                return t[-n:], x[-n:], periods
    return t[:0], x[:0], 0
