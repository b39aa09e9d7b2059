"""Fault-injection matrix: every fault kind injected into short runs (graph and headless).

Prints one row per case (log, /diagnostics, result, crash, data changed by an
outsider) and the totals with their goals: silent 0, crashes 0, runs an
outsider changed 0. Run after ``source scripts/env.sh``:

    python benchmarks/bench_fault_matrix.py [--only SUBSTRING] [--workers N]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

from drive_testing.fault_matrix import run_matrix, table


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--only', help='run only the cases whose name contains this')
    parser.add_argument('--workers', type=int, default=1, help='cases run at once (default 1)')
    args = parser.parse_args()
    started = time.monotonic()
    with tempfile.TemporaryDirectory(prefix='fault_matrix_') as directory:
        outcomes = run_matrix(Path(directory),
                              select=lambda case: not args.only or args.only in case.name,
                              progress=lambda o: print(f'  {o.where:8s} {o.case}: '
                                                       f'{"reported" if o.reported else "NOT reported"}'
                                                       f'{", " + o.crashed if o.crashed else ""}',
                                                       flush=True),
                              workers=args.workers)
    print()
    print(table(outcomes))
    print(f'\n{time.monotonic() - started:.0f} s wall')
    bad = [o for o in outcomes if not o.reported or o.crashed or o.changed]
    return 1 if bad else 0


if __name__ == '__main__':
    sys.exit(main())
