"""Shared timing loops of the benchmark scripts (best of N, wall and CPU time)."""
from __future__ import annotations

import time
from typing import Any, Callable, Sequence


def best_of(repeats: int, setup: Callable[[], Any], run: Callable[[Any], None]):
    """Run setup() then run(obj) `repeats` times; (best wall s, best CPU s, last obj)."""
    best_wall = best_cpu = float('inf')
    obj = None
    for _ in range(repeats):
        obj = setup()
        w0, c0 = time.perf_counter(), time.process_time()
        run(obj)
        best_wall = min(best_wall, time.perf_counter() - w0)
        best_cpu = min(best_cpu, time.process_time() - c0)
    return best_wall, best_cpu, obj


def per_call_us(fn: Callable[[Any], Any], samples: Sequence, n: int, repeats: int = 5) -> float:
    """Best-of-`repeats` cost of fn(sample) in microseconds over n calls cycling samples."""
    count = len(samples)

    def run(_):
        for k in range(n):
            fn(samples[k % count])

    wall, _, _ = best_of(repeats, lambda: None, run)
    return wall / n * 1e6
