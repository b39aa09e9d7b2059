"""Scale-out of a design study: points per minute serial, on a LocalCluster, on separate programs.

    python benchmarks/bench_study.py [--study sampled_hysteresis_torque_deficit] [--duration 0.05]
                                     [--workers 2] [--points 16]

Runs the same points (the first --points of the study, run length --duration
s of sim time) three ways, each into a fresh results directory:
  serial    run_point one after the other in this process (no Dask);
  local     run_study on a LocalCluster of --workers single-threaded processes;
  programs  run_study on `dask scheduler` + --workers `dask worker` programs
            started as separate processes on this machine (as on a cluster).
Worker imports are done before timing (steady state). Prints points/minute, the speed-up over serial, the per-task overhead
((wall x workers - sum of the points' own run times) / points) and the
resident memory of each worker process after its run (psutil).
"""
from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

from drive_bringup.dask_programs import DaskPrograms
from drive_bringup.study import dask_client, load_study, run_point, run_study
from drive_bringup.study_cli import find_study


def worker_memory_mb(client) -> list[float]:
    import psutil
    rss = client.run(lambda: psutil.Process().memory_info().rss)
    return sorted(round(v / 1e6) for v in rss.values())


def _warm_up() -> None:
    import drive_bringup.headless  # noqa: F401 - the imports a first point would pay for
    import drive_bringup.report  # noqa: F401


def clustered(study, out: Path, client, workers: int) -> dict:
    client.run(_warm_up)          # measure the steady state, not each worker's first imports
    started = time.monotonic()
    run = run_study(study, out, client=client, progress=False, plots=False)
    wall = time.monotonic() - started
    busy = float(run.table['wall_time_s'].sum())
    return {'wall': wall, 'busy': busy, 'memory': worker_memory_mb(client),
            'overhead': (wall * workers - busy) / len(study.points)}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--study', default='sampled_hysteresis_torque_deficit')
    parser.add_argument('--duration', type=float, default=0.5, help='sim time per point, s')
    parser.add_argument('--workers', type=int, default=2)
    parser.add_argument('--points', type=int, default=16)
    args = parser.parse_args(argv)

    study = load_study(find_study(args.study))
    from drive_bringup.study import apply_values, point_key
    points = []
    for p in study.points[:args.points]:
        scenario = apply_values(p.scenario, {'duration': args.duration})
        points.append(dataclasses.replace(p, scenario=scenario, key=point_key(scenario, p.repeat)))
    study = dataclasses.replace(study, points=points)
    n = len(points)
    print(f'{args.study}: {n} points of {args.duration} s sim time, {args.workers} workers')

    _warm_up()
    started = time.monotonic()
    rows = [run_point(p) for p in points]
    serial = time.monotonic() - started
    per_point = sum(r['wall_time_s'] for r in rows) / n
    print(f'serial     {60 * n / serial:7.1f} points/min  ({per_point:.3f} s per point)')

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        with dask_client(workers=args.workers) as client:
            local = clustered(study, tmp / 'local', client, args.workers)
        with DaskPrograms(tmp / 'programs', workers=args.workers) as programs:
            from distributed import Client
            with Client(programs.address) as client:
                remote = clustered(study, tmp / 'programs_out', client, args.workers)
    for name, r in (('local', local), ('programs', remote)):
        print(f'{name:9s}  {60 * n / r["wall"]:7.1f} points/min  speed-up {serial / r["wall"]:.2f}x  '
              f'per-task overhead {r["overhead"]:.3f} s  worker RSS {r["memory"]} MB')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
