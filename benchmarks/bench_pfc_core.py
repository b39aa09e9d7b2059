#!/usr/bin/env python3
"""Per-sample cost of PfcCore.update (average current control, 000 ch. III).

Run: ``source scripts/env.sh && python benchmarks/bench_pfc_core.py [--samples N]``.
Feeds a 25.4 V RMS / 60 Hz rectified line, a sinusoidal inductor current and
80 V output (one line cycle of precomputed samples, reused), default parameters.
At 80 kHz a real-time budget would be 12.5 us per sample.
"""
from __future__ import annotations

import argparse
import math

from drive_common.samples import PfcSample
from pfc_controller.core import PfcCore
from timing import per_call_us  # benchmarks/timing.py

T_S = 12.5e-6


def bench(n: int, params: dict) -> float:
    core = PfcCore(params)
    samples = []
    for k in range(1334):
        s = abs(math.sin(2 * math.pi * 60 * k * T_S))
        samples.append(PfcSample(k, k * T_S, 35.92 * s, 3.9 * s, 80.0 + 0.5 * math.sin(k * 0.01)))
    return per_call_us(core.update, samples, n)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument('--samples', type=int, default=50000)
    args = ap.parse_args()
    for label, params in [('default (duty feed-forward on)', {}),
                          ('seed structure (duty feed-forward off)', {'duty_feedforward': False})]:
        us = bench(args.samples, params)
        print(f'{label:45s} {us:6.2f} us/sample (best of 5 x {args.samples})')


if __name__ == '__main__':
    main()
