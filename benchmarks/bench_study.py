"""Scale-out of a design study: points per minute serial, on a LocalCluster, on separate programs.

    python benchmarks/bench_study.py [--study sampled_hysteresis_torque_deficit] [--duration S]
                                     [--workers 2] [--points 16] [--refine-to 1000]

Runs the same points (the first --points of the study, or of its grid refined to
--refine-to points: each numeric axis resampled evenly between its extremes; run
length --duration s of sim time, default the study's) three ways, each into a fresh
results directory:
  serial    run_point one after the other in this process (no Dask), with the
            per-point split: set-up (cores), loop, arrays + metrics, journal write;
  local     run_study on a LocalCluster of --workers single-threaded processes;
  programs  run_study on `dask scheduler` + --workers `dask worker` programs
            started as separate processes on this machine (as on a cluster).
Each process runs one point before timing (steady state: imports,
compiled kernels and file caches loaded). Prints points/minute against
the old figure and the goal, the speed-up over serial, the per-point overhead
((wall x workers - sum of the points' own run times) / points) and the resident
memory of each worker process after its run (psutil).
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import tempfile
import time
from pathlib import Path

import numpy as np

from drive_bringup.dask_programs import DaskPrograms
from drive_bringup.study import (append_rows, apply_values, batch_size, dask_client, load_study,
                                 point_key, run_point, run_study, sample)
from drive_bringup.study_cli import find_study


OLD_POINTS_PER_MIN = 780.0   # the shipped 30 points in 2.3 s on 2 workers, one Dask task per point
GOAL_POINTS_PER_MIN = 10 * OLD_POINTS_PER_MIN


def refined_points(study, total: int) -> list:
    """The first ``total`` points of the study's grid with each numeric axis resampled evenly
    between its extremes, every axis's count scaled by the same factor (product >= total)."""
    factor = (total / len(study.points)) ** (1.0 / len(study.axes))
    axes = []
    for a in study.axes:
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in a.values):
            axes.append(a)
            continue
        num = max(2, math.ceil(len(a.values) * factor))
        axes.append(dataclasses.replace(a, values=tuple(np.linspace(min(a.values), max(a.values), num).tolist())))
    plan = sample(axes, 'grid')
    if len(plan) < total:
        raise SystemExit(f'--refine-to {total}: the grid of {study.name} gives only {len(plan)} points')
    points = []
    for values in plan[:total]:
        scenario = apply_values(study.scenario, {t: values[a.name] for a in axes for t in a.targets})
        points.append(dataclasses.replace(study.points[0], key=point_key(scenario, 0), values=values,
                                          repeat=0, scenario=scenario))
    return points


def worker_memory_mb(client) -> list[float]:
    import psutil
    rss = client.run(lambda: psutil.Process().memory_info().rss)
    return sorted(round(v / 1e6) for v in rss.values())


def _warm_up(point=None) -> None:
    """The imports, compiled-kernel loads and file caches a first point would pay for."""
    import drive_bringup.headless  # noqa: F401
    import drive_bringup.report  # noqa: F401
    if point is not None:
        run_point(point)


def clustered(study, out: Path, client, workers: int) -> dict:
    client.run(_warm_up, study.points[0])    # the steady state, not each worker's first point
    started = time.monotonic()
    run = run_study(study, out, client=client, progress=False, plots=False)
    wall = time.monotonic() - started
    busy = float(run.table['wall_time_s'].sum())
    return {'wall': wall, 'busy': busy, 'memory': worker_memory_mb(client),
            'overhead': (wall * workers - busy) / len(study.points)}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--study', default='sampled_hysteresis_torque_deficit')
    parser.add_argument('--duration', type=float, help="sim time per point, s (default: the study's)")
    parser.add_argument('--workers', type=int, default=2)
    parser.add_argument('--points', type=int, default=16)
    parser.add_argument('--refine-to', type=int, metavar='N',
                        help='run N points of the grid refined to N points (then --points is ignored)')
    args = parser.parse_args(argv)

    study = load_study(find_study(args.study))
    points = refined_points(study, args.refine_to) if args.refine_to else study.points[:args.points]
    if args.duration is not None:
        points = [dataclasses.replace(p, scenario=s, key=point_key(s, p.repeat)) for p in points
                  for s in (apply_values(p.scenario, {'duration': args.duration}),)]
    study = dataclasses.replace(study, points=points)
    n = len(points)
    duration = points[0].scenario.duration
    print(f'{args.study}: {n} points of {duration} s sim time, {args.workers} workers; '
          f'old figure {OLD_POINTS_PER_MIN:.0f} points/min, goal {GOAL_POINTS_PER_MIN:.0f}')

    _warm_up(points[0])
    split: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as tmp:
        started = time.monotonic()
        rows = [run_point(p, split=split) for p in points]
        serial = time.monotonic() - started
        size = batch_size(n, args.workers)
        started = time.monotonic()
        with open(Path(tmp) / 'points.jsonl', 'a') as journal:
            for i in range(0, n, size):
                append_rows(journal, rows[i:i + size], 'bench')
        split['write'] = time.monotonic() - started
    per_point = sum(r['wall_time_s'] for r in rows) / n
    print(f'serial     {60 * n / serial:7.1f} points/min  ({1e3 * per_point:.2f} ms per point: '
          + ', '.join(f'{k} {1e3 * v / n:.2f} ms' for k, v in split.items()) + ')')

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        with dask_client(workers=args.workers) as client:
            local = clustered(study, tmp / 'local', client, args.workers)
        with DaskPrograms(tmp / 'programs', workers=args.workers) as programs:
            from distributed import Client
            with Client(programs.address) as client:
                remote = clustered(study, tmp / 'programs_out', client, args.workers)
    for name, r in (('local', local), ('programs', remote)):
        rate = 60 * n / r['wall']
        print(f'{name:9s}  {rate:7.1f} points/min  ({rate / OLD_POINTS_PER_MIN:.1f}x the old figure)  '
              f'speed-up {serial / r["wall"]:.2f}x  per-point overhead {1e3 * r["overhead"]:.2f} ms  '
              f'worker RSS {r["memory"]} MB')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
