"""run_scenario: run a scenario through the ROS graph (or headless), record, report.

    run_scenario default                      # bags/default/ (bag, report, figures)
    run_scenario path/to/file.yaml --out bags/mine
    run_scenario default --headless           # same cores stepped in one process, no ROS
    run_scenario default --live               # and watch it in Foxglove (ws://localhost:8765)
    run_scenario --list
    run_scenario default --join-domain        # in your ROS_DOMAIN_ID (default: a private one)
    run_scenario default --params-file p.yaml # standard ROS 2 parameter file over the scenario

Exit codes: 0 ok, 1 the run failed (message says why), 2 bad scenario or
arguments, 130 interrupted (all nodes stopped).
"""
from __future__ import annotations

import argparse
import os
import signal
import sys
from contextlib import nullcontext
from pathlib import Path
from typing import Callable

from drive_bringup.scenario import Scenario, ScenarioError, find_scenario, load_scenario, scenario_dir
from drive_common.namespaces import normalized
from drive_common.parameter_files import ParameterFileError, read_params_file
from drive_common.starter import watch_starter
from drive_common.cli_output import quiet_on_closed_pipe


def default_out_dir(name: str) -> Path:
    """bags/<name> under the workspace root (or the current directory)."""
    root = Path(os.environ.get('DTC_WORKSPACE', Path.cwd()))
    return root / 'bags' / name


def _fresh_dir(path: Path, overwrite: bool) -> Path:
    if path.exists() and any(path.iterdir()):
        if not overwrite:
            raise ScenarioError(f'output directory {path} exists and is not empty '
                                '(use --out for another one or --overwrite)')
        import shutil
        shutil.rmtree(path)
    return path


def print_summary(summary: dict, out: Path) -> None:
    """The terminal summary of a recorded run: where things are, metrics, seed checks."""
    print(f'\n{summary["scenario"]} ({summary["seed_reference"]}): '
          f'{summary["sim_time"]:.4f} s sim in {summary["wall_time"]:.1f} s wall, '
          f'{summary["samples_per_second"]:.0f} samples/s')
    data = summary['bag'] or f'none (headless: {out / "trajectory.npz"})'
    print(f'  bag     {data}\n  report  {out / "report.json"}\n  figures {out / "figures"}')
    for name, value in summary['metrics'].items():
        print(f'  {name:45s} {value:.6g}' if isinstance(value, float) else f'  {name:45s} {value}')
    for row in summary['checks']:
        seed = '' if row['seed'] is None else f'seed {row["seed"]:g}, '
        sim = row['simulated']
        sim = f'{sim:.4g}' if isinstance(sim, float) else str(sim)
        print(f'  [{"pass" if row["pass"] else "FAIL"}] {row["label"]}: {seed}simulated {sim} '
              f'({row["criterion"]})')


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog='run_scenario', description=__doc__.split('\n')[0])
    parser.add_argument('scenario', nargs='?', help='scenario name (see --list) or YAML path')
    parser.add_argument('--list', action='store_true', help='list the shipped scenarios')
    parser.add_argument('--out', type=Path, help='output directory (default bags/<name>)')
    parser.add_argument('--overwrite', action='store_true', help='replace an existing output directory')
    parser.add_argument('--headless', action='store_true',
                        help='step the cores directly in this process (no ROS)')
    parser.add_argument('--no-record', action='store_true', help='do not record a bag')
    where = parser.add_mutually_exclusive_group()
    where.add_argument('--isolate', action='store_true',
                       help='run in a private DDS domain, localhost only (the default)')
    where.add_argument('--domain-id', type=int, metavar='N',
                       help='run in DDS domain N (e.g. to watch with ros2 tools) instead of a private one')
    where.add_argument('--join-domain', action='store_true',
                       help="run in the current ROS_DOMAIN_ID instead of a private one")
    parser.add_argument('--params-file', type=Path,
                        help='ROS 2 parameter file (node: {ros__parameters: ...} or /**:) over the '
                        "scenario's node parameters")
    parser.add_argument('--duration', type=float,
                        help='run only the first DURATION s of the scenario (with --live: any DURATION s, '
                             'longer too, the last setpoints holding)')
    parser.add_argument('--live', action='store_true',
                        help='also start drive_logger live_view: watch the run in Foxglove at ws://localhost:8765')
    parser.add_argument('--namespace', default='', metavar='NAME',
                        help='run the drive under the ROS namespace /NAME (its /clock, /diagnostics '
                             'and /parameter_events too), so several drives share a domain')
    parser.add_argument('--pause-at', type=float, action='append', default=[], metavar='T',
                        help='hold the plant at sim time T s (repeatable) until '
                             '`ros2 service call /scenario_runner/resume std_srvs/srv/Trigger`; '
                             'look at or change the held graph meanwhile')
    return parser


def prepare_run(args, check: Callable[[Scenario], None] | None = None) -> tuple:
    """(scenario, fresh output dir) from the parsed scenario, --duration, --params-file, --out, --overwrite.

    Every check (the arguments, ``check(scenario)``, the programs a graph run starts) comes
    before the output directory is touched. --duration shortens a run; with --live it may also
    lengthen it (the last setpoints hold), to leave time to turn a knob in the viewer.
    """
    scenario = load_scenario(find_scenario(args.scenario))
    if args.duration is not None:
        live = getattr(args, 'live', False)
        scenario = scenario.with_duration(args.duration) if live else scenario.shortened(args.duration)
    params_file = getattr(args, 'params_file', None)
    if params_file is not None:
        scenario = scenario.with_parameters(str(params_file), read_params_file(params_file))
    domain_id = getattr(args, 'domain_id', None)
    if domain_id is not None and not 0 <= domain_id <= 232:
        raise ScenarioError(f'--domain-id {domain_id}: must be in 0..232')
    if check is not None:
        check(scenario)
    if not getattr(args, 'headless', False):     # (a controller core is imported by load_scenario)
        from drive_bringup.runner import check_programs
        check_programs(scenario, record=not getattr(args, 'no_record', False),
                       live=getattr(args, 'live', False))
    return scenario, _fresh_dir(args.out or default_out_dir(scenario.name), args.overwrite)


_signals_received: list[int] = []


def _interrupt(signum, frame):
    _signals_received.append(signum)
    raise KeyboardInterrupt


@quiet_on_closed_pipe
def main(argv=None) -> int:
    """Ctrl-C and SIGTERM interrupt from the first instruction on, even when the shell of a
    non-interactive script started this in the background with SIGINT ignored; so does the
    end of a starter that named itself (drive_common.starter)."""
    _signals_received.clear()
    previous = {sig: signal.signal(sig, _interrupt) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        if not watch_starter():
            return 130
        return _main(argv)
    except KeyboardInterrupt:
        print('interrupted: all nodes stopped', file=sys.stderr)
        return 130
    except Exception:
        # The interrupt raised inside rclpy's C++ layer (taking a message) comes out as
        # pybind11's "RuntimeError: Unable to convert call argument": still the interrupt.
        if not _signals_received:
            raise
        print('interrupted: all nodes stopped', file=sys.stderr)
        return 130
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    if args.list:
        for path in sorted(scenario_dir().glob('*.yaml')):
            sc = load_scenario(path)
            summary = ' '.join(sc.description.split())
            print(f'{sc.name:42s} {sc.seed_reference[:28]:28s} {summary[:70]}')
        return 0
    if not args.scenario:
        print('run_scenario: name a scenario (or --list)', file=sys.stderr)
        return 2
    for option, given, what in (('--live', args.live, 'watches'), ('--pause-at', args.pause_at, 'holds')):
        if given and args.headless:
            print(f'run_scenario: {option} {what} the ROS graph; it cannot be combined with --headless',
                  file=sys.stderr)
            return 2
    try:
        normalized(args.namespace)
    except ValueError as exc:
        print(f'[run_scenario] error: --namespace: {exc}', file=sys.stderr)
        return 2
    try:
        scenario, out = prepare_run(args, check=lambda sc: _check_pauses(sc, args.pause_at))
    except (ScenarioError, ParameterFileError) as exc:
        print(f'[run_scenario] error: {exc}', file=sys.stderr)
        return 2
    if args.headless:
        return _run_headless(scenario, out)
    from drive_bringup.report import write_report
    from drive_bringup.runner import GraphRunner, main_guard

    def run() -> int:
        from drive_common.processes import reserve_domain
        if args.domain_id is not None:
            os.environ['ROS_DOMAIN_ID'] = str(args.domain_id)
        shared = args.domain_id is not None or args.join_domain
        # default: a private domain, so two runs never mix their graphs
        with nullcontext() if shared else reserve_domain() as domain:
            result = GraphRunner(scenario, out, domain_id=domain, namespace=args.namespace,
                                 record=not args.no_record, live=args.live, pause_at=args.pause_at).run()
        if result.bag is not None:
            summary = write_report(scenario, result, out)
            print_summary(summary, out)
        return _judge(scenario, result.end_state, result.fault_kinds)

    return main_guard(run)


def _check_pauses(scenario: Scenario, pause_at: list[float]) -> None:
    """ScenarioError for a --pause-at time the run never reaches (0 < T < duration)."""
    for t in pause_at:
        if not 0.0 < t < scenario.duration:
            raise ScenarioError(f'--pause-at {t}: must be inside the run, 0 < T < {scenario.duration:g} s')


def _run_headless(scenario, out: Path) -> int:
    """The scenario's cores in this process: trajectory.npz, then the report a graph run writes."""
    from drive_bringup.headless import run_headless
    from drive_bringup.report import write_report
    result = run_headless(scenario)
    out.mkdir(parents=True, exist_ok=True)
    arrays = result.arrays()
    np_path = out / 'trajectory.npz'
    result.save(np_path, arrays)
    print(f'[{scenario.name}] headless: trajectory -> {np_path}')
    print_summary(write_report(scenario, result, out, arrays=arrays), out)
    return _judge(scenario, result.end_state, result.fault_kinds)


def _judge(scenario, end_state: str, fault_kinds) -> int:
    """Print how the run ended (stderr with the reason if it fails); the exit code."""
    from drive_bringup.report import fault_verdict
    code, line = fault_verdict(scenario, end_state, fault_kinds)
    if code:
        print(f'run_scenario: {line}', file=sys.stderr)
    else:
        print(f'[run_scenario] {line}')
    return code


if __name__ == '__main__':
    raise SystemExit(main())
