"""Scenario reports: metrics, seed checks and figures from a bag or a headless run.

Both sources are turned into one flat arrays dict, keys
``'<topic without leading slash>.<field>'`` (``'plant/state.phase_current'``,
``'dtc/status.torque_estimate'``, ``'plant/state.time'``), which is what the
scenario metric functions take: ``fn(arrays, **options) -> float``. A
scenario's ``metrics`` and ``checks`` name such functions (or aliases:
``name: {metric: <function>, ...options}``); they live in the
``drive_bringup.metrics_*`` modules (one per family of seed results).
"""
from __future__ import annotations

import importlib
import json
from pathlib import Path
from typing import Any, Callable

import numpy as np

from drive_bringup.scenario import Scenario

METRIC_MODULES = ('drive_bringup.metrics_two_phase', 'drive_bringup.metrics_three_phase',
                  'drive_bringup.metrics_pfc')


def flatten_columns(columns: dict[str, dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """{topic: {field: array}} (drive_logger.analysis.data) -> flat arrays dict ('t' -> 'time')."""
    flat = {}
    for topic, cols in columns.items():
        key = topic.lstrip('/')
        for name, values in cols.items():
            flat[f'{key}.{"time" if name == "t" else name}'] = values
    return flat


def metric_function(name: str) -> Callable[..., float]:
    for module_name in METRIC_MODULES:
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if exc.name != module_name:
                raise
            continue
        fn = getattr(module, name, None)
        if callable(fn) and not name.startswith('_'):
            return fn
    raise KeyError(f'no metric named {name!r} in {", ".join(METRIC_MODULES)}')


def evaluate_metrics(scenario: Scenario, arrays: dict[str, np.ndarray]) -> dict[str, Any]:
    """Every metric the scenario names (in ``metrics`` or ``checks``); errors become strings."""
    names = list(scenario.metrics) + [c.metric for c in scenario.checks
                                      if c.metric not in scenario.metrics]
    values: dict[str, Any] = {}
    for name in names:
        options = dict(scenario.metrics.get(name) or {})
        function = options.pop('metric', name)   # an alias: {metric: <function>, ...options}
        try:
            values[name] = float(metric_function(function)(arrays, **options))
        except Exception as exc:  # noqa: BLE001 - one bad metric must not hide the others
            values[name] = f'error: {type(exc).__name__}: {exc}'
    return values


def check_rows(scenario: Scenario, values: dict[str, Any]) -> list[dict[str, Any]]:
    """Reproduction-table rows: seed value, simulated value, criterion, pass/fail."""
    rows = []
    for check in scenario.checks:
        value = values.get(check.metric)
        number = value if isinstance(value, float) else None
        rows.append({'scenario': scenario.name, 'reference': scenario.seed_reference,
                     'label': check.label, 'metric': check.metric, 'seed': check.seed,
                     'simulated': number if number is not None else value,
                     'criterion': check.criterion(), 'pass': check.evaluate(number)})
    return rows


def write_report(scenario: Scenario, result, out_dir: Path, columns=None) -> dict[str, Any]:
    """Analyse a recorded run: report.json, figures/*.png; returns the summary."""
    from drive_logger.analysis.data import load_columns
    from drive_logger.analysis.figures import draw_all
    from drive_logger.analysis_cli import json_safe, summarize

    out_dir = Path(out_dir)
    if columns is None:
        columns = load_columns(str(result.bag))
    values = evaluate_metrics(scenario, flatten_columns(columns))
    rows = check_rows(scenario, values)
    figures = draw_all(columns, out_dir / 'figures')
    summary = {
        'scenario': scenario.name, 'seed_reference': scenario.seed_reference,
        'description': scenario.description, 'bag': str(result.bag) if result.bag else None,
        'sim_time': result.final_time, 'wall_time': result.wall_time,
        'samples_per_second': result.samples_per_second,
        'metrics': values, 'checks': rows, 'analysis': summarize(columns),
        'figures': figures,
        'headline': {'scenario': scenario.name, 'sim_time_s': result.final_time,
                     'wall_time_s': round(result.wall_time, 2),
                     'samples_per_second': round(result.samples_per_second),
                     **{k: v for k, v in values.items()},
                     'checks_passed': f'{sum(r["pass"] for r in rows)}/{len(rows)}'},
    }
    summary = json_safe(summary)
    (out_dir / 'report.json').write_text(json.dumps(summary, indent=2))
    return summary
