#!/usr/bin/env python3
"""Compiled kernels (drive_common.compiled, numba) against the same code interpreted.

Run: ``source scripts/env.sh && python benchmarks/bench_compiled.py [--duration 0.05]``.
Each figure is measured in a subprocess twice, compiled (warm cache) and with
``NUMBA_DISABLE_JIT=1``, and printed with its goal:

* DtcCore.update per sample, two-phase six-switch (bench_dtc_core's samples): goal <= 15 us;
  the same for the three-phase modes (dtifc, pmsm, four-switch with the proposed drop
  compensation), goal <= 15 us each;
* PfcCore.update per sample (bench_pfc_core's line cycle): goal <= 12.5 us (80 kHz real time);
* FrontEnd alone ('fe only' of bench_front_end, EMI filter on): goal >= 1x real time;
* your own controller beside the DTC: the example core (drive_examples
  hysteresis_current_controller, its comparator compiled the same way) per sample on
  bench_dtc_core's samples, and its scenario ``example_hysteresis_current_control``
  headless (no goal: reported);
* headless ``two_phase_six_switch_torque_step`` (plant + DtcCore at 33.3 us),
  ``fstp_voltage_model_proposed_compensation`` and ``three_phase_dtifc_sensorless``, the whole
  ``run_headless`` with its set-up (files read, cores built): goal >= 1x real time;
  ``pfc_no_load_fig_3_5`` (plant with grid, bridge and boost + DTC + PFC cores, all in the
  fused loop): goal >= 5x real time;
* the headless loop alone (time inside ``CoSimulation.run``, the fused compiled loop of
  drive_bringup.fused) of the default scenario run for 0.5 s: goal >= 300k samples/s with
  every sample recorded (its default), >= 600k samples/s (20x real time) without recording;
* cold start (empty cache: import, compile, first sample): goal <= 30 s; warm start
  (cached machine code): goal <= 3 s;
* start-up to the first samples of a fresh process, compiled (warm cache) against
  interpreted, best of 3: a headless run (``run_scenario --headless`` of the default
  scenario, 3 samples) and the nodes' cores (the plant and dtc_controller node modules
  imported, their per-sample cores built and stepped 3 samples); goal: compiling adds < 1 s.
"""
from __future__ import annotations

import argparse
import importlib
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
THREE_PHASE = (('three_phase_dtifc', {}), ('three_phase_pmsm', {}),
               ('three_phase_four_switch', {'voltage_drop.compensation': 'proposed'}))


def _real_time(name: str, duration: float) -> float:
    """Sim seconds per wall second of a shipped scenario run headless for duration [s] (best of
    3 runs: the machine is shared)."""
    from drive_bringup.headless import run_headless
    from drive_bringup.scenario import load_scenario
    from drive_common.uris import resolve_path
    scenario = load_scenario(resolve_path(f'package://drive_bringup/scenarios/{name}.yaml'))
    duration = min(duration, scenario.duration)
    run_headless(scenario.shortened(duration))     # compile / load (both paths: a scripted change runs per sample)
    best = float('inf')
    for _ in range(3):
        t0 = time.perf_counter()
        run_headless(scenario.shortened(duration))
        best = min(best, time.perf_counter() - t0)
    return duration / best


def _loop_rate(name: str, duration: float, record_every: int | None) -> float:
    """Samples per wall second spent inside CoSimulation.run (set-up excluded) of a shipped
    scenario run headless for duration [s] (longer than the file's: the last value is held)."""
    from bldc_plant_sim.core.cosim import CoSimulation
    from drive_bringup.headless import run_headless
    from drive_bringup.scenario import load_scenario
    from drive_common.uris import resolve_path
    scenario = load_scenario(resolve_path(f'package://drive_bringup/scenarios/{name}.yaml'))
    run_headless(scenario.shortened(0.002), record_every=record_every)   # compile / load
    scenario.duration = duration
    spent = [0.0]
    run = CoSimulation.run

    def timed(self, *args, **kwargs):
        t0 = time.perf_counter()
        try:
            return run(self, *args, **kwargs)
        finally:
            spent[0] += time.perf_counter() - t0
    CoSimulation.run = timed
    try:
        best = min(_spent_in(run_headless, scenario, record_every, spent) for _ in range(3))
    finally:
        CoSimulation.run = run
    return round(duration / scenario.node_parameters['plant']['base_tick']) / best


def _spent_in(run_headless, scenario, record_every, spent) -> float:
    spent[0] = 0.0
    run_headless(scenario, record_every=record_every)
    return spent[0]


def child_figures(duration: float) -> dict:
    """The figures of this process's JIT setting (module doc)."""
    import bench_dtc_core
    import bench_front_end
    import bench_pfc_core
    bench_front_end.print = lambda *a, **k: None      # its bench() prints a line per case
    from drive_examples.hysteresis_current_controller import HysteresisCurrentCore
    from timing import per_call_us
    fe_rate = bench_front_end.bench('fe only', duration, 2, 25.4, 100.0, 80.0, False, duty=0.55)
    own = HysteresisCurrentCore({'torque_reference': 1.0})
    return {'dtc_us': bench_dtc_core.bench('two_phase_six_switch', 20000, {}),
            'own_us': per_call_us(own.update, bench_dtc_core.samples(), 20000),
            'own_real_time': _real_time('example_hysteresis_current_control', duration),
            **{f'dtc_{mode}_us': bench_dtc_core.bench(mode, 20000, extra) for mode, extra in THREE_PHASE},
            'pfc_us': bench_pfc_core.bench(20000, {}),
            'fe_real_time': fe_rate * bench_front_end.TICK,
            'dtc_real_time': _real_time('two_phase_six_switch_torque_step', duration),
            'fstp_real_time': _real_time('fstp_voltage_model_proposed_compensation', duration),
            'dtifc_real_time': _real_time('three_phase_dtifc_sensorless', duration),
            'pfc_real_time': _real_time('pfc_no_load_fig_3_5', duration),
            'loop_recorded': _loop_rate('two_phase_six_switch_torque_step', 0.5, None),
            'loop_unrecorded': _loop_rate('two_phase_six_switch_torque_step', 0.5, 0)}


def child_startup() -> dict:
    """Seconds from start-up to the first sample of each compiled core (DTC, PFC, front end)."""
    t0 = time.perf_counter()
    import bench_dtc_core
    import bench_front_end
    import bench_pfc_core
    bench_front_end.print = lambda *a, **k: None
    bench_dtc_core.bench('two_phase_six_switch', 1, {})
    for mode, extra in THREE_PHASE:
        bench_dtc_core.bench(mode, 1, extra)
    bench_pfc_core.bench(1, {})
    bench_front_end.bench('fe only', 1e-4, 1, 25.4, 100.0, 80.0, False, duty=0.55)
    return {'startup': time.perf_counter() - t0}


def child_first_samples(path: str) -> dict:
    """Import, build and step 3 samples of the default scenario: 'headless' (the fused loop
    of run_headless) or 'nodes' (the node modules and the per-sample cores they step)."""
    from drive_bringup.headless import run_headless
    from drive_bringup.scenario import find_scenario, load_scenario
    if path == 'nodes':       # what the node processes import
        for module in ('bldc_plant_sim.plant_node', 'dtc_controller.dtc_node'):
            importlib.import_module(module)
    scenario = load_scenario(find_scenario('two_phase_six_switch_torque_step')).shortened(1e-4)
    return {'steps': run_headless(scenario, fused=path == 'headless').final_step}


def start_up(path: str, jit: bool, repeats: int = 3) -> float:
    """Best wall time [s] of a fresh process from exec to its first samples (child_first_samples)."""
    best = float('inf')
    for _ in range(repeats):
        begun = time.perf_counter()
        run_child('first', {'NUMBA_DISABLE_JIT': '0' if jit else '1'}, path)
        best = min(best, time.perf_counter() - begun)
    return best


def run_child(what: str, env_extra: dict, *args: str) -> dict:
    env = dict(os.environ, **env_extra)
    out = subprocess.run([sys.executable, __file__, '--child', what, *args], env=env, check=True,
                         capture_output=True, text=True, cwd=HERE)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument('--duration', type=float, default=0.05, help='sim time of the timed runs [s]')
    ap.add_argument('--child', help=argparse.SUPPRESS)
    ap.add_argument('path', nargs='?', help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        children = {'figures': lambda: child_figures(args.duration), 'startup': child_startup,
                    'first': lambda: child_first_samples(args.path)}
        print(json.dumps(children[args.child]()))
        return
    with tempfile.TemporaryDirectory() as cache:
        cold = run_child('startup', {'NUMBA_CACHE_DIR': cache, 'NUMBA_DISABLE_JIT': '0'})['startup']
        warm = run_child('startup', {'NUMBA_CACHE_DIR': cache, 'NUMBA_DISABLE_JIT': '0'})['startup']
    fig = {mode: run_child('figures', {'NUMBA_DISABLE_JIT': flag}, '--duration', str(args.duration))
           for mode, flag in (('compiled', '0'), ('interpreted', '1'))}
    c, i = fig['compiled'], fig['interpreted']
    rows = [('DtcCore.update, two-phase six-switch [us/sample]', 'dtc_us', '<= 15'),
            *((f'DtcCore.update, {mode} [us/sample]', f'dtc_{mode}_us', '<= 15') for mode, _ in THREE_PHASE),
            ('your own controller: example HysteresisCurrentCore.update [us/sample]', 'own_us', ''),
            ('PfcCore.update [us/sample]', 'pfc_us', '<= 12.5'),
            ('FrontEnd alone, filter on [x real time]', 'fe_real_time', '>= 1'),
            ('headless two_phase_six_switch_torque_step [x real time]', 'dtc_real_time', '>= 1'),
            ('headless fstp_voltage_model_proposed_compensation [x real time]', 'fstp_real_time', '>= 1'),
            ('headless three_phase_dtifc_sensorless [x real time]', 'dtifc_real_time', '>= 1'),
            ('headless pfc_no_load_fig_3_5 [x real time]', 'pfc_real_time', '>= 5'),
            ('headless example_hysteresis_current_control (your own controller) [x real time]',
             'own_real_time', ''),
            ('headless loop, default scenario, every sample recorded [samples/s]', 'loop_recorded', '>= 300k'),
            ('headless loop, default scenario, no recording [samples/s]', 'loop_unrecorded', '>= 600k')]
    print(f"{'figure':66s} {'compiled':>10s} {'interpreted':>12s} {'goal':>8s}")
    for label, key, goal in rows:
        digits = 0 if c[key] > 1000 else 3
        print(f'{label:66s} {c[key]:10.{digits}f} {i[key]:12.{digits}f} {goal:>8s}')
    print(f"{'cold start, empty cache: import + compile + 1 sample [s]':66s} {cold:10.2f} {'':12s} {'<= 30':>8s}")
    print(f"{'warm start, cached [s]':66s} {warm:10.2f} {'':12s} {'<= 3':>8s}")
    for path, label in (('headless', 'headless run'), ('nodes', "nodes' cores")):
        compiled, interpreted = start_up(path, True), start_up(path, False)
        print(f"{label + ', start-up to the first samples [s]':66s} {compiled:10.2f} {interpreted:12.2f}")
        print(f"{'  compiling adds [s]':66s} {compiled - interpreted:10.2f} {'':12s} {'< 1':>8s}")


if __name__ == '__main__':
    main()
