"""reproduce: run every shipped scenario that checks a seed result; print the table.

    reproduce [--only TEXT] [--ros] [--out reports] [--docs docs/reproduction.md]

Headless in 2 processes by default (--ros: through the ROS graph, recorded bags); --docs (alias
--readme) refreshes the table between the markers of a file. Each row: scenario, seed reference,
what is checked, the seed's and the simulated value, the criterion (seed ± tolerance, or
bounds) and pass/fail. Exit code 0 when every check passes, 1 otherwise.
"""
from __future__ import annotations

import argparse
import json
import multiprocessing
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from drive_bringup.report import check_rows, evaluate_metrics
from drive_bringup.scenario import load_scenario, scenario_dir
from drive_common.cli_output import quiet_on_closed_pipe


def run_one(path: str, ros: bool, bag_root: str) -> tuple[list[dict], float, str | None]:
    """(check rows, wall time, error) of one scenario."""
    started = time.monotonic()
    scenario = load_scenario(path)
    try:
        if ros:
            from drive_analysis.arrays import flatten_columns
            from drive_bringup.runner import GraphRunner
            from drive_common.processes import reserve_domain
            from drive_analysis.bag_columns import load_columns
            out = Path(bag_root) / scenario.name
            if out.exists():
                import shutil
                shutil.rmtree(out)
            with reserve_domain() as domain:
                result = GraphRunner(scenario, out, domain_id=domain, progress=lambda m: None).run()
            arrays = flatten_columns(load_columns(str(result.bag)))
        else:
            from drive_bringup.headless import run_headless
            arrays = run_headless(scenario).arrays()
        rows = check_rows(scenario, evaluate_metrics(scenario, arrays))
        return rows, time.monotonic() - started, None
    except Exception as exc:  # noqa: BLE001 - reported in the table
        rows = check_rows(scenario, {})
        return rows, time.monotonic() - started, f'{type(exc).__name__}: {exc}'


def _fmt(value) -> str:
    if value is None:
        return '—'
    if isinstance(value, float):
        return f'{value:.4g}'
    return str(value)


def markdown(rows: list[dict]) -> str:
    lines = ['| scenario | seed ref. | check | seed | simulated | criterion | result |',
             '|---|---|---|---|---|---|---|']
    for r in rows:
        lines.append(f'| {r["scenario"]} | {r["reference"]} | {r["label"]} | {_fmt(r["seed"])} | '
                     f'{_fmt(r["simulated"])} | {r["criterion"]} | {"pass" if r["pass"] else "FAIL"} |')
    return '\n'.join(lines)


BEGIN, END = '<!-- reproduction table: begin -->', '<!-- reproduction table: end -->'


def _check_markers(path: Path) -> str:
    """The text of path; SystemExit with one line if it lacks the BEGIN/END markers."""
    text = path.read_text() if path.is_file() else ''
    if BEGIN not in text or END not in text:
        raise SystemExit(f'{path}: markers {BEGIN} / {END} not found')
    return text


def update_readme(path: Path, table: str) -> None:
    """Put table between the BEGIN/END markers of path (which must have both): a README or a docs page."""
    text = _check_markers(path)
    head, rest = text.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    path.write_text(f'{head}{BEGIN}\n{table.strip()}\n{END}{tail}')


@quiet_on_closed_pipe
def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog='reproduce', description=__doc__.split('\n')[0])
    parser.add_argument('--only', default='', help='run scenarios whose name contains this')
    parser.add_argument('--ros', action='store_true', help='through the ROS graph (recorded)')
    parser.add_argument('--out', type=Path, default=Path('reports'))
    parser.add_argument('--jobs', type=int, default=2)
    parser.add_argument('--docs', '--readme', type=Path, action='append', default=[],
                        help='replace the table between the markers of this file (a README or a '
                             'documentation page: docs/reproduction.md); may be given more than once')
    args = parser.parse_args(argv)
    for path in args.docs:          # before the run, not after it
        _check_markers(path)
    paths = [p for p in sorted(scenario_dir().glob('*.yaml'))
             if args.only in p.stem and load_scenario(p).checks]
    if not paths:
        print('no scenario with checks matches', file=sys.stderr)
        return 2
    started = time.monotonic()
    rows, notes = [], []
    jobs = 1 if args.ros else max(1, args.jobs)
    # spawn, not fork: a caller with threads and compiled code loaded (a test process, rclpy)
    # must not be forked (a forked worker died abruptly in CI)
    with ProcessPoolExecutor(max_workers=jobs, mp_context=multiprocessing.get_context('spawn')) as pool:
        futures = [pool.submit(run_one, str(p), args.ros, str(args.out / 'bags')) for p in paths]
        for path, future in zip(paths, futures):
            scenario_rows, wall, error = future.result()
            status = 'error: ' + error if error else f'{sum(r["pass"] for r in scenario_rows)}/{len(scenario_rows)} pass'
            print(f'{path.stem:45s} {wall:6.1f} s  {status}', flush=True)
            rows += scenario_rows
            if error:
                notes.append(f'- {path.stem}: {error}')
    wall = time.monotonic() - started
    table = markdown(rows)
    passed = sum(r['pass'] for r in rows)
    footer = (f'\n\n{passed}/{len(rows)} checks pass; {len(paths)} scenarios '
              f'({"ROS graph" if args.ros else "headless"}) in {wall:.0f} s wall.\n')
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / 'reproduction.md').write_text(table + footer + ('\n'.join(notes) + '\n' if notes else ''))
    (args.out / 'reproduction.json').write_text(json.dumps(rows, indent=2, default=str))
    for path in args.docs:
        update_readme(path, table + footer)
    print()
    print(table + footer)
    return 0 if passed == len(rows) else 1


if __name__ == '__main__':
    raise SystemExit(main())
