"""study: run a design study (a scenario at many parameter points) on Dask.

    study STUDY [--workers N | --scheduler tcp://HOST:8786] [--out DIR] [--retry-failed] [--dry-run]
    study --list

STUDY is a path or a shipped study's name. Points already in DIR/points.jsonl (default DIR
studies/<name>) are skipped; writes results.parquet, results.csv, summary.txt and plots/*.png.
Exit code 0 when every point is ok or a protection trip, 1 when any point failed (error /
timeout), 2 for a bad study file or an unreachable cluster (docs/studies.md).
"""
from __future__ import annotations

import argparse
import sys
from functools import partial
from pathlib import Path

from drive_bringup.scenario import ScenarioError, find_shipped, shipped_dir
from drive_common.cli_output import quiet_on_closed_pipe


study_dir = partial(shipped_dir, 'studies')              # the shipped studies
find_study = partial(find_shipped, kind='studies')      # a path as given, or a shipped study's name


@quiet_on_closed_pipe
def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog='study', description=__doc__.split('\n')[0])
    parser.add_argument('study', nargs='?', help='study file or shipped study name')
    parser.add_argument('--scheduler', help='address of a running Dask scheduler (tcp://HOST:8786)')
    parser.add_argument('--workers', type=int, help='LocalCluster worker processes (default: cores)')
    parser.add_argument('--out', type=Path, help='results directory (default studies/<name>)')
    parser.add_argument('--retry-failed', action='store_true', help='re-run error / timeout points')
    parser.add_argument('--dry-run', action='store_true', help='validate and list the points only')
    parser.add_argument('--no-progress', action='store_true', help='no progress bar')
    parser.add_argument('--list', action='store_true', help='list the shipped studies')
    args = parser.parse_args(argv)
    if args.list:
        for path in sorted(study_dir().glob('*.yaml')):
            print(path.stem)
        return 0
    if not args.study:
        parser.error('a study is required (or --list)')
    if args.workers is not None and args.workers < 1:
        print('study: --workers: must be >= 1', file=sys.stderr)
        return 2

    from drive_bringup.study import load_study, run_study, summary_text
    try:
        study = load_study(find_study(args.study))
    except ScenarioError as exc:     # a StudyError too
        print('study: ' + ' '.join(str(exc).split()), file=sys.stderr)   # one line
        return 2
    out = args.out or Path('studies') / study.name
    if args.dry_run:
        for point in study.points:
            print(point.key, point.repeat, point.values)
        print(f'{len(study.points)} points')
        return 0
    try:
        result = run_study(study, out, scheduler=args.scheduler, workers=args.workers,
                           retry_failed=args.retry_failed, progress=not args.no_progress)
    except OSError as exc:        # scheduler unreachable (distributed raises OSError / TimeoutError)
        print(f'study: cannot reach the Dask scheduler {args.scheduler}: {exc}', file=sys.stderr)
        return 2
    print(summary_text(study, result.table))
    print(f'ran {result.ran}, skipped {result.skipped} (done before) in {result.wall_time_s:.1f} s; '
          f'results in {out}/results.parquet, results.csv, plots/')
    failed = result.table['status'].isin(['error', 'timeout']).any()
    return 1 if failed else 0


if __name__ == '__main__':
    raise SystemExit(main())
