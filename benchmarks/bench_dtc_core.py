#!/usr/bin/env python3
"""Per-sample cost of DtcCore.update for the two-phase modes (target <= 15 us on this machine).

Run: ``source scripts/env.sh && python benchmarks/bench_dtc_core.py [--samples N]``.
Uses a synthetic trapezoidal back-EMF table (360 points) and measurements
rotating through all sectors, with the default estimation options
(diode-clamped voltage model, open-phase back-EMF).
"""
from __future__ import annotations

import argparse
import math

import numpy as np

from drive_common.samples import DriveSample
from dtc_controller.core.backemf_table import BackEmfTable
from dtc_controller.core.controller import DtcCore
from timing import per_call_us  # benchmarks/timing.py


def table() -> BackEmfTable:
    th = np.arange(360) * (2 * np.pi / 360)

    def trap(x):
        return np.clip(-np.sin(x) * 2.0, -1.0, 1.0)
    return BackEmfTable.from_phase_constants(*(0.0573 * trap(th - s) for s in (0, 2 * np.pi / 3, 4 * np.pi / 3)), 2)


def samples() -> list[DriveSample]:
    """1000 measurements rotating through every sector (any controller core's input)."""
    out = []
    for k in range(1000):
        th = (k * 0.0123) % (2 * math.pi)
        i_a, i_b = 3 * math.sin(th), 3 * math.sin(th - 2.1)
        out.append(DriveSample(k, k * 25e-6, (i_a, i_b, -i_a - i_b), 56.57, 28.28, 0, th, 0, 30.0))
    return out


def bench(mode: str, n: int, extra: dict) -> float:
    core = DtcCore({'mode': mode, 'torque_reference': 1.0, **extra}, table())
    return per_call_us(core.update, samples(), n)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument('--samples', type=int, default=50000)
    args = ap.parse_args()
    cases = [('two_phase_six_switch', {}), ('two_phase_four_switch', {}),
             ('two_phase_six_switch', {'speed_loop.enabled': True, 'speed_reference': 30.0}),
             ('two_phase_six_switch', {'flux_control.enabled': True}),
             ('three_phase_dtifc', {}), ('three_phase_pmsm', {}),
             ('three_phase_four_switch', {'voltage_drop.compensation': 'proposed'})]
    for mode, extra in cases:
        us = bench(mode, args.samples, extra)
        label = mode + (' ' + ','.join(f'{k}={v}' for k, v in extra.items()) if extra else '')
        print(f'{label:70s} {us:6.2f} us/sample (best of 5 x {args.samples})')


if __name__ == '__main__':
    main()
