"""Design studies: one scenario run headless at many parameter points, on Dask (no rclpy).

Every point is a complete, validated scenario (the base with the point's values applied), run
by :func:`drive_bringup.headless.run_headless` in batches (:func:`batch_size`) of one
``dask.distributed`` task each, on a local or a running cluster. Each finished batch appends a
row per point to ``points.jsonl`` at once, so re-running a study skips the points done (key =
hash of the point's full parameters); the table goes to ``results.parquet`` / ``results.csv``.
The study file and the status of a point: docs/studies.md.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import re
import socket
import subprocess
import time
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from functools import partial
from itertools import product
from pathlib import Path
from typing import Any, Callable, Iterator

import numpy as np

from drive_bringup.report import evaluate_metrics
from drive_bringup.scenario import (NODE_SCHEMAS, Event, Scenario, ScenarioError, find_scenario,
                                    load_scenario)
# the same checks as scenarios (load_study turns their ScenarioError into a StudyError)
from drive_bringup.scenario import _check_metrics, _entry, _fail, _mapping, _number, read_named_file
from drive_common.parameters import ParameterError
from drive_common.uris import resolve_path as resolve_package_path

TOP_KEYS = {'name', 'description', 'scenario', 'duration', 'set', 'parameters', 'sampling',
            'samples', 'seed', 'repeats', 'repeat_seed', 'metrics', 'timeout'}
AXIS_KEYS = {'name', 'targets', 'values', 'range', 'min', 'max', 'log'}
SAMPLINGS = ('grid', 'zip', 'random', 'latin_hypercube')
STATUSES = ('ok', 'protection_trip', 'error', 'timeout')
EVENT_TARGET = re.compile(r'events\[(\d+)\]\.(.+)')
JOURNAL = 'points.jsonl'
TASKS_PER_WORKER = 8       # Dask tasks per worker a study is split into, at least (load balance)
MAX_BATCH = 64             # points per Dask task, at most
SOURCE_ROOT = str(Path(__file__).resolve().parents[2])


class StudyError(ScenarioError):
    """A study file is malformed; the message names file, key and reason."""


@dataclass(frozen=True)
class Axis:
    """One varied parameter: its column name, the targets it sets, its values or bounds."""
    name: str
    targets: tuple[str, ...]
    values: tuple = ()
    low: float | None = None
    high: float | None = None
    log: bool = False

    def from_unit(self, u: np.ndarray) -> np.ndarray:
        """Map u in [0, 1) onto [low, high] (geometrically if log)."""
        if self.log:
            return np.exp(np.log(self.low) + u * (np.log(self.high) - np.log(self.low)))
        return self.low + u * (self.high - self.low)


@dataclass(frozen=True)
class Point:
    """One run of the study: the axis values, the repeat index and the complete scenario."""
    key: str
    values: dict[str, Any]
    repeat: int
    scenario: Scenario


@dataclass
class Study:
    path: Path
    name: str
    description: str
    scenario: Scenario              # the base, with ``set`` and ``metrics`` applied
    axes: list[Axis]
    points: list[Point]
    metrics: dict[str, dict]
    timeout: float = 600.0
    repeats: int = 1


def _count(value, path: Path, key: str, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise _fail(path, key, f'expected an integer >= {minimum}, got {value!r}')
    return value


def _scalar(value) -> Any:
    """numpy scalars -> plain Python (YAML/JSON/parameter schemas want int, float, str, bool)."""
    return value.item() if isinstance(value, np.generic) else value


# ---- applying values to a scenario ---------------------------------------------------------

def check_target(scenario: Scenario, target: str) -> str | None:
    """None if ``target`` names something of ``scenario``, else the reason it does not."""
    if target == 'duration':
        return None
    match = EVENT_TARGET.fullmatch(target)
    if match:
        index, name = int(match.group(1)), match.group(2)
        if index >= len(scenario.events):
            return f'the scenario has {len(scenario.events)} event(s)'
        event = scenario.events[index]
        if name != 'time' and name not in scenario.schema(event.node).names():
            return f'{event.node} has no parameter {name!r}'
        return None
    node, _, name = target.partition('.')
    if node not in NODE_SCHEMAS and node != 'controller':
        return (f'unknown target (allowed: duration, events[i].time, events[i].<parameter>, '
                f'<node>.<parameter> with node in {", ".join(NODE_SCHEMAS)}, controller)')
    if node not in scenario.node_parameters:
        return f'node {node!r} is not in the scenario'
    if name not in scenario.schema(node).names():
        return f'{node} has no parameter {name!r}'
    return None


def apply_values(scenario: Scenario, changes: dict[str, Any]) -> Scenario:
    """The scenario with ``{target: value}`` applied and re-validated (ParameterError / ValueError)."""
    duration = scenario.duration
    overrides = {node: dict(params) for node, params in scenario.overrides.items()}
    events = [[e.time, e.node, dict(e.parameters)] for e in scenario.events]
    for target, value in changes.items():
        value = _scalar(value)
        if isinstance(value, str):
            value = resolve_package_path(value)
        match = EVENT_TARGET.fullmatch(target)
        if target == 'duration':
            duration = float(value)
        elif match:
            index, name = int(match.group(1)), match.group(2)
            if name == 'time':
                events[index][0] = float(value)
            else:
                events[index][2][name] = value
        else:
            node, _, name = target.partition('.')
            overrides[node][name] = value
    if duration <= 0.0:
        raise ValueError(f'duration {duration} s must be > 0')
    snapshots = {}
    for node, params in overrides.items():
        try:
            snapshots[node] = scenario.schema(node).resolve(params)
        except ParameterError as exc:
            raise ParameterError(f'{node}: {exc}') from exc
    new_events = []
    for t, node, params in events:
        if not 0.0 <= t < duration:
            raise ValueError(f'event time {t} s is outside [0, duration = {duration} s)')
        try:
            scenario.schema(node).validate_changes(snapshots[node], params)
        except ParameterError as exc:
            raise ParameterError(f'event at {t} s, {node}: {exc}') from exc
        new_events.append(Event(t, node, params))
    if [e.time for e in new_events] != sorted(e.time for e in new_events):
        raise ValueError('events out of time order')
    return dataclasses.replace(scenario, duration=duration, node_parameters=snapshots,
                               overrides=overrides, events=new_events)


def point_key(scenario: Scenario, repeat: int) -> str:
    """Hash of the point's full parameters (every node's snapshot, events, duration, repeat, metrics)."""
    def portable(value):
        if isinstance(value, str) and value.startswith(SOURCE_ROOT):
            return 'src:' + value[len(SOURCE_ROOT):]     # same key in any checkout
        return value
    content = {
        'duration': scenario.duration,
        'nodes': {n: {k: portable(v) for k, v in sorted(p.items())}
                  for n, p in sorted(scenario.node_parameters.items())},
        'events': [[e.time, e.node, {k: portable(v) for k, v in sorted(e.parameters.items())}]
                   for e in scenario.events],
        'metrics': scenario.metrics,
        'repeat': repeat,
    }
    if scenario.controller is not None:       # your own controller: its core is part of the point
        content['controller'] = scenario.controller.core
    text = json.dumps(content, sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


# ---- loading --------------------------------------------------------------------------------

def _axis(raw, index: int, path: Path, scenario: Scenario, sampling: str) -> Axis:
    key = f'parameters[{index}]'
    if not isinstance(raw, dict):
        raise _fail(path, key, f'expected a mapping, got {type(raw).__name__}')
    _entry(raw, path, key, sorted(AXIS_KEYS), ('name', 'targets'))
    name = raw['name']
    if not isinstance(name, str) or not name:
        raise _fail(path, f'{key}.name', 'expected a non-empty string')
    key = f'parameters.{name}'
    targets = raw['targets']
    if isinstance(targets, str):
        targets = [targets]
    if not isinstance(targets, list) or not targets or not all(isinstance(t, str) for t in targets):
        raise _fail(path, f'{key}.targets', 'expected a non-empty list of targets')
    for i, target in enumerate(targets):
        reason = check_target(scenario, target)
        if reason:
            raise _fail(path, f'{key}.targets[{i}]', f'{target!r}: {reason}')
    log = raw.get('log', False)
    if not isinstance(log, bool):
        raise _fail(path, f'{key}.log', f'expected true or false, got {log!r}')
    given = [k for k in ('values', 'range', 'min') if k in raw]
    if sampling in ('random', 'latin_hypercube'):
        if 'min' not in raw or 'max' not in raw:
            raise _fail(path, key, f'{sampling} sampling needs min and max')
        low, high = _number(raw['min'], path, f'{key}.min'), _number(raw['max'], path, f'{key}.max')
        if low >= high or (log and low <= 0.0):
            raise _fail(path, key, f'need 0 < min < max for log, min < max otherwise (got {low}, {high})')
        return Axis(name, tuple(targets), low=low, high=high, log=log)
    if len(given) != 1 or given[0] == 'min':
        raise _fail(path, key, f'{sampling} sampling needs exactly one of values, range')
    if 'values' in raw:
        values = raw['values']
        if not isinstance(values, list) or not values:
            raise _fail(path, f'{key}.values', 'expected a non-empty list')
        for i, v in enumerate(values):
            if not isinstance(v, (int, float, str, bool)):
                raise _fail(path, f'{key}.values[{i}]', f'expected a number, string or bool, got {v!r}')
        return Axis(name, tuple(targets), values=tuple(values))
    spec = raw['range']
    if not isinstance(spec, dict) or set(spec) - {'start', 'stop', 'num', 'log'} or \
            not {'start', 'stop', 'num'} <= set(spec):
        raise _fail(path, f'{key}.range', 'expected {start, stop, num[, log]}')
    start = _number(spec['start'], path, f'{key}.range.start')
    stop = _number(spec['stop'], path, f'{key}.range.stop')
    num = _count(spec['num'], path, f'{key}.range.num')
    if spec.get('log', log):
        if start <= 0.0 or stop <= 0.0:
            raise _fail(path, f'{key}.range', 'a log range needs start, stop > 0')
        values = np.geomspace(start, stop, num)
    else:
        values = np.linspace(start, stop, num)
    return Axis(name, tuple(targets), values=tuple(float(v) for v in values))


def sample(axes: list[Axis], sampling: str, samples: int = 0, seed: int = 0) -> list[dict[str, Any]]:
    """The list of {axis name: value} points of the sampling plan."""
    names = [a.name for a in axes]
    if sampling == 'grid':
        return [dict(zip(names, combo)) for combo in product(*(a.values for a in axes))]
    if sampling == 'zip':
        return [dict(zip(names, combo)) for combo in zip(*(a.values for a in axes), strict=True)]
    rng = np.random.default_rng(seed)
    if sampling == 'random':
        unit = rng.random((samples, len(axes)))
    else:   # latin_hypercube: one sample in each of `samples` equal strata per axis
        unit = np.column_stack([(rng.permutation(samples) + rng.random(samples)) / samples
                                for _ in axes])
    columns = [a.from_unit(unit[:, j]) for j, a in enumerate(axes)]
    return [{a.name: float(columns[j][i]) for j, a in enumerate(axes)} for i in range(samples)]


def load_study(path: str | Path) -> Study:
    """Load and validate a study file and every point of it; raise StudyError naming what is wrong."""
    try:
        return _load_study(Path(path))
    except ScenarioError as exc:        # the value checks are those of scenarios
        raise StudyError(str(exc)) from exc


def _load_study(path: Path) -> Study:
    raw, name = read_named_file(path, TOP_KEYS, ('scenario', 'parameters'))
    ref = raw['scenario']
    if not isinstance(ref, str) or not ref:
        raise _fail(path, 'scenario', 'expected a scenario name or path')
    local = path.parent / ref
    try:
        base = load_scenario(local if local.suffix in ('.yaml', '.yml') and local.exists()
                             else find_scenario(ref))
    except ScenarioError as exc:
        raise _fail(path, 'scenario', str(exc)) from exc

    fixed = _mapping(raw.get('set'), path, 'set')
    for target in fixed:
        reason = check_target(base, target)
        if reason:
            raise _fail(path, f'set.{target}', reason)
    if 'duration' in raw:      # a shorter run drops the scenario's events it would never reach
        duration = _number(raw['duration'], path, 'duration')
        base = base.with_duration(duration)
        for target in fixed:
            match = EVENT_TARGET.fullmatch(target)
            if match and int(match.group(1)) >= len(base.events):
                raise _fail(path, f'set.{target}', f'the event is at or after duration = {duration} s')
        fixed = {**fixed, 'duration': duration}
    try:
        base = apply_values(base, fixed)
    except (ParameterError, ValueError) as exc:
        raise _fail(path, 'set', str(exc)) from exc

    metrics = _mapping(raw.get('metrics'), path, 'metrics') or dict(base.metrics)
    if not metrics:
        raise _fail(path, 'metrics', 'no metrics: name some here or in the scenario')
    _check_metrics(path, metrics)
    base = dataclasses.replace(base, metrics=metrics, checks=[], figures=[], record=False)

    sampling = raw.get('sampling', 'grid')
    if sampling not in SAMPLINGS:
        raise _fail(path, 'sampling', f'{sampling!r} is not one of {", ".join(SAMPLINGS)}')
    samples = seed = 0
    if sampling in ('random', 'latin_hypercube'):
        if 'samples' not in raw:
            raise _fail(path, 'samples', f'required with sampling {sampling}')
        samples = _count(raw['samples'], path, 'samples')
        seed = _count(raw.get('seed', 0), path, 'seed', minimum=0)
    elif 'samples' in raw or 'seed' in raw:
        raise _fail(path, 'samples' if 'samples' in raw else 'seed', f'not used by sampling {sampling}')
    if not isinstance(raw['parameters'], list) or not raw['parameters']:
        raise _fail(path, 'parameters', 'expected a non-empty list of varied parameters')
    axes = [_axis(a, i, path, base, sampling) for i, a in enumerate(raw['parameters'])]
    names = [a.name for a in axes]
    reserved = set(names) & (set(metrics) | {'key', 'repeat', 'status', 'reason', 'wall_time_s',
                                               'git_revision', 'worker'})
    if len(set(names)) != len(names) or reserved:
        raise _fail(path, 'parameters', 'parameter names must be unique and differ from the '
                    'metric and result column names')
    if sampling == 'zip' and len({len(a.values) for a in axes}) != 1:
        raise _fail(path, 'parameters', 'zip sampling needs lists of equal length')

    repeats = _count(raw.get('repeats', 1), path, 'repeats')
    repeat_seed = raw.get('repeat_seed', 'plant.sensors.seed')
    reason = check_target(base, repeat_seed) if isinstance(repeat_seed, str) else 'expected a target'
    if reason:
        raise _fail(path, 'repeat_seed', reason)
    timeout = _number(raw.get('timeout', 600.0), path, 'timeout')
    if timeout <= 0.0:
        raise _fail(path, 'timeout', 'must be > 0 s')

    points = []
    for values in sample(axes, sampling, samples, seed):
        changes = {t: v for a in axes for t in a.targets for v in (values[a.name],)}
        for repeat in range(repeats):
            if repeats > 1:
                changes = {**changes, repeat_seed: repeat}
            try:
                scenario = apply_values(base, changes)
            except (ParameterError, ValueError) as exc:
                at = ', '.join(f'{k}={v!r}' for k, v in values.items())
                raise _fail(path, 'parameters', f'point {at}: {exc}') from exc
            points.append(Point(point_key(scenario, repeat), dict(values), repeat, scenario))
    return Study(path=path, name=name, description=str(raw.get('description', '')), scenario=base,
                 axes=axes, points=points, metrics=metrics, timeout=timeout, repeats=repeats)


# ---- one point (the Dask task) --------------------------------------------------------------

class PointTimeout(Exception):
    """A point ran past its wall-time limit."""


def _deadline(seconds: float) -> Callable:
    end = time.monotonic() + seconds

    def check(_cosim) -> None:
        if time.monotonic() > end:
            raise PointTimeout(f'still running after {seconds:g} s wall')
    return check


def run_point(point: Point, timeout: float = 600.0, split: dict | None = None) -> dict[str, Any]:
    """Run one point headless; its result row. Never raises: failures become a status.

    split: if given, the point's wall time [s] is added to its 'setup', 'loop' and
    'arrays_metrics' entries (building the cores, the run, arrays and metrics).
    """
    from drive_bringup.headless import run_headless
    started = time.monotonic()
    row = {'key': point.key, 'repeat': point.repeat, **point.values, 'status': 'ok', 'reason': ''}
    try:
        result = run_headless(point.scenario, on_tick=_deadline(timeout))
        arrays = result.arrays()
        values = evaluate_metrics(point.scenario, arrays)
        if split is not None:
            for name, seconds in (('setup', result.setup_time), ('loop', result.wall_time - result.setup_time),
                                  ('arrays_metrics', time.monotonic() - started - result.wall_time)):
                split[name] = split.get(name, 0.0) + seconds
        for name, value in values.items():
            if isinstance(value, str):                  # a metric that raised: NaN + reason
                row['reason'] += f'{name}: {value}; '
                value = math.nan
            row[name] = value
        protection = arrays.get('plant/state.protection')
        if protection is not None and np.any(protection.astype(np.int64)):
            row['status'] = 'protection_trip'
            first = int(np.flatnonzero(protection.astype(np.int64))[0])
            row['reason'] += (f'protection word {int(protection[first])} at '
                              f'{arrays["plant/state.time"][first]:.6g} s')
    except PointTimeout as exc:
        row.update(status='timeout', reason=str(exc))
    except Exception as exc:  # noqa: BLE001 - a failing point never stops the study
        row.update(status='error', reason=f'{type(exc).__name__}: {exc}')
    row['reason'] = row['reason'].rstrip('; ')
    row['wall_time_s'] = time.monotonic() - started
    row['worker'] = f'{socket.gethostname()}:{os.getpid()}'
    return row


def run_points(points: list[Point], timeout: float = 600.0) -> list[dict[str, Any]]:
    """Run a batch of points one after the other (one Dask task); their rows, in order."""
    return [run_point(p, timeout) for p in points]


def batch_size(points: int, workers: int, per_worker: int = TASKS_PER_WORKER,
               largest: int = MAX_BATCH) -> int:
    """Points per Dask task: enough tasks per worker to balance the load (per_worker each),
    few enough that scheduling costs little against the points (at most ``largest`` per task)."""
    return max(1, min(largest, points // (max(1, workers) * per_worker)))


# ---- the study on Dask ----------------------------------------------------------------------

def git_revision() -> str:
    """The project's git revision (short hash; '-dirty' with uncommitted changes to src/), or 'unknown'."""
    try:
        rev = subprocess.run(['git', 'rev-parse', '--short=12', 'HEAD'], cwd=SOURCE_ROOT,
                             capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(['git', 'status', '--porcelain', '--untracked-files=no', '--', '.'],
                               cwd=SOURCE_ROOT, capture_output=True, text=True).stdout.strip()
        return rev + ('-dirty' if dirty else '')
    except (OSError, subprocess.CalledProcessError):
        return 'unknown'


def read_journal(out_dir: Path) -> dict[str, dict]:
    """Rows of the points already done, by key (the last row of a key wins)."""
    rows = {}
    journal = Path(out_dir) / JOURNAL
    if journal.exists():
        for line in journal.read_text().splitlines():
            try:
                row = json.loads(line)
            except json.JSONDecodeError:
                continue          # a line cut short by a crash
            rows[row['key']] = row
    return rows


def append_rows(journal, rows: list[dict], revision: str) -> None:
    """Append a finished batch's rows (with the git revision) to the open journal, synced to disk."""
    for row in rows:
        row['git_revision'] = revision
        journal.write(json.dumps(row, default=_scalar) + '\n')
    journal.flush()
    os.fsync(journal.fileno())


@dataclass
class StudyRun:
    """What one ``run_study`` call did."""
    table: Any                     # pandas.DataFrame, one row per point of the study
    out_dir: Path
    ran: int                       # points run by this call
    skipped: int                   # points found done in the journal
    wall_time_s: float
    files: list[Path] = field(default_factory=list)


@contextmanager
def dask_client(scheduler: str | None = None, workers: int | None = None) -> Iterator:
    """A dask.distributed Client: on the cluster at ``scheduler``, else on a new LocalCluster
    of ``workers`` single-threaded worker processes (default: one per core), closed on exit."""
    from distributed import Client, LocalCluster
    if scheduler:
        with Client(scheduler, timeout='30s') as client:
            yield client
        return
    with LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1,
                      processes=True, dashboard_address=None) as cluster, Client(cluster) as client:
        yield client


def run_study(study: Study, out_dir: str | Path, *, scheduler: str | None = None,
              workers: int | None = None, client=None, retry_failed: bool = False,
              progress: bool = True, plots: bool = True) -> StudyRun:
    """Run every point not yet done as a Dask task; write the table, summary and plots.

    client: an open dask.distributed Client (else one is opened from scheduler / workers).
    retry_failed: also re-run points recorded as error or timeout.
    """
    from distributed import as_completed
    from tqdm import tqdm

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    started = time.monotonic()
    done = read_journal(out_dir)
    redo = ('error', 'timeout') if retry_failed else ()
    todo = [p for p in study.points if p.key not in done or done[p.key]['status'] in redo]
    todo = list({p.key: p for p in todo}.values())          # a point listed twice runs once
    revision = git_revision()
    if todo:
        with ExitStack() as stack:
            if client is None:
                client = stack.enter_context(dask_client(scheduler, workers))
            size = batch_size(len(todo), len(client.scheduler_info()['workers']))
            batches = [todo[i:i + size] for i in range(0, len(todo), size)]
            futures = client.map(partial(run_points, timeout=study.timeout), batches, pure=False,
                                 key=[f'study-{study.name}-{b[0].key}-{len(b)}-{time.time_ns()}'
                                      for b in batches])
            batch_of = {f.key: b for f, b in zip(futures, batches)}
            journal = stack.enter_context(open(out_dir / JOURNAL, 'a'))
            bar = stack.enter_context(tqdm(total=len(todo), desc=study.name, unit='point',
                                           disable=not progress, dynamic_ncols=True))
            for future in as_completed(futures):
                batch = batch_of[future.key]
                try:
                    rows = future.result()
                except Exception as exc:  # noqa: BLE001 - e.g. KilledWorker: recorded, not raised
                    rows = [{'key': point.key, 'repeat': point.repeat, **point.values,
                             'status': 'error', 'reason': f'{type(exc).__name__}: {exc}',
                             'wall_time_s': math.nan, 'worker': ''} for point in batch]
                append_rows(journal, rows, revision)
                done.update(zip((p.key for p in batch), rows))
                bar.update(len(batch))
                future.release()
    table = results_table(study, done)
    files = write_results(study, table, out_dir, plots=plots)
    return StudyRun(table, out_dir, len(todo), len(study.points) - len(todo),
                    time.monotonic() - started, files)


def results_table(study: Study, rows: dict[str, dict]):
    """One row per point of the study, in plan order: parameters, metrics, status, wall time, revision."""
    import pandas as pd
    columns = (['key', 'repeat'] + [a.name for a in study.axes] + list(study.metrics)
               + ['status', 'reason', 'wall_time_s', 'git_revision', 'worker'])
    records = [{c: rows[p.key].get(c, math.nan) for c in columns} for p in study.points if p.key in rows]
    table = pd.DataFrame.from_records(records, columns=columns)
    for metric in study.metrics:
        table[metric] = pd.to_numeric(table[metric], errors='coerce')
    return table


def summary_text(study: Study, table) -> str:
    """A short plain-text summary: counts per status, wall time, each metric's range."""
    lines = [f'study {study.name}: {len(table)}/{len(study.points)} points']
    counts = table['status'].value_counts()
    lines.append('status: ' + ', '.join(f'{s} {int(counts.get(s, 0))}' for s in STATUSES))
    if len(table):
        lines.append(f'wall time per point: median {table["wall_time_s"].median():.2f} s, '
                     f'total {table["wall_time_s"].sum():.1f} s')
    for metric in study.metrics:
        column = table[metric].dropna()
        if len(column):
            lo, hi = column.idxmin(), column.idxmax()
            at = lambda i: ', '.join(f'{a.name}={table.at[i, a.name]:.4g}' if isinstance(
                table.at[i, a.name], float) else f'{a.name}={table.at[i, a.name]}' for a in study.axes)
            lines.append(f'{metric}: min {column.min():.4g} ({at(lo)}), max {column.max():.4g} ({at(hi)})')
    for _, row in table[table['status'] != 'ok'].head(5).iterrows():
        lines.append(f'  {row["status"]}: ' + ', '.join(f'{a.name}={row[a.name]}' for a in study.axes)
                     + f': {row["reason"]}')
    return '\n'.join(lines)


def write_results(study: Study, table, out_dir: Path, plots: bool = True) -> list[Path]:
    """results.parquet, results.csv, summary.txt and the plots; the files written."""
    out_dir = Path(out_dir)
    files = [out_dir / 'results.parquet', out_dir / 'results.csv', out_dir / 'summary.txt']
    table.to_parquet(files[0], engine='pyarrow', index=False)
    table.to_csv(files[1], index=False)
    files[2].write_text(summary_text(study, table) + '\n')
    if plots:
        from drive_bringup.study_plots import plot_study
        files += plot_study(study, table, out_dir)
    return files
