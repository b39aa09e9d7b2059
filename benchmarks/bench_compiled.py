#!/usr/bin/env python3
"""Compiled kernels (drive_common.compiled, numba) against the same code interpreted.

Run: ``source scripts/env.sh && python benchmarks/bench_compiled.py [--duration 0.05]``.
Each figure is measured in a subprocess twice, compiled (warm cache) and with
``NUMBA_DISABLE_JIT=1``, and printed with its goal:

* PfcCore.update per sample (bench_pfc_core's line cycle): goal <= 12.5 us (80 kHz real time);
* headless ``pfc_no_load_fig_3_5`` (plant with grid, bridge and boost + DTC + PFC cores):
  goal >= 1x real time;
* cold start (empty cache: import, compile, first sample): goal <= 30 s; warm start
  (cached machine code): goal <= 3 s.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def child_figures(duration: float) -> dict:
    """Per-sample PFC cost [us] and headless real-time factor of this process's JIT setting."""
    from bench_pfc_core import bench
    from drive_bringup.headless import run_headless
    from drive_testing.compiled_parity import scenario_path
    from drive_bringup.scenario import load_scenario
    pfc_us = bench(20000, {})
    scenario = load_scenario(scenario_path('pfc_no_load_fig_3_5')).shortened(duration)
    run_headless(scenario.shortened(min(duration, 0.002)))          # compile / load outside the timing
    t0 = time.perf_counter()
    run_headless(scenario)
    return {'pfc_us': pfc_us, 'real_time': duration / (time.perf_counter() - t0)}


def child_startup() -> dict:
    """Seconds from interpreter start-up to the first PfcCore sample done."""
    t0 = time.perf_counter()
    from drive_common.samples import PfcSample
    from pfc_controller.core import PfcCore
    PfcCore({}).update(PfcSample(0, 0.0, 1.0, 1.0, 80.0))
    return {'startup': time.perf_counter() - t0}


def run_child(what: str, env_extra: dict, *args: str) -> dict:
    env = dict(os.environ, **env_extra)
    out = subprocess.run([sys.executable, __file__, '--child', what, *args], env=env, check=True,
                         capture_output=True, text=True, cwd=HERE)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument('--duration', type=float, default=0.05, help='sim time of the headless run [s]')
    ap.add_argument('--child', help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(child_figures(args.duration) if args.child == 'figures' else child_startup()))
        return
    with tempfile.TemporaryDirectory() as cache:
        cold = run_child('startup', {'NUMBA_CACHE_DIR': cache, 'NUMBA_DISABLE_JIT': '0'})['startup']
        warm = run_child('startup', {'NUMBA_CACHE_DIR': cache, 'NUMBA_DISABLE_JIT': '0'})['startup']
    fig = {mode: run_child('figures', {'NUMBA_DISABLE_JIT': flag}, '--duration', str(args.duration))
           for mode, flag in (('compiled', '0'), ('interpreted', '1'))}
    c, i = fig['compiled'], fig['interpreted']
    print(f"{'figure':44s} {'compiled':>10s} {'interpreted':>12s} {'goal':>10s}")
    print(f"{'PfcCore.update [us/sample]':44s} {c['pfc_us']:10.2f} {i['pfc_us']:12.2f} {'<= 12.5':>10s}")
    print(f"{'headless pfc_no_load_fig_3_5 [x real time]':44s} {c['real_time']:10.3f} "
          f"{i['real_time']:12.3f} {'>= 1':>10s}")
    print(f"{'cold start, empty cache [s]':44s} {cold:10.2f} {'':12s} {'<= 30':>10s}")
    print(f"{'warm start, cached [s]':44s} {warm:10.2f} {'':12s} {'<= 3':>10s}")


if __name__ == '__main__':
    main()
