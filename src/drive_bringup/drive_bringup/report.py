"""Scenario reports: metrics, seed checks and figures from a bag or a headless run.

Both sources are turned into one flat arrays dict (:mod:`drive_analysis.arrays`;
a bag through :func:`drive_analysis.arrays.flatten_columns`), on which the
scenario's ``metrics`` and ``checks`` are evaluated by name through the one
metric registry, :mod:`drive_analysis.registry`.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from drive_analysis import registry
from drive_analysis.arrays import columns_of, flatten_columns
from drive_bringup.scenario import Scenario

FAULT_EXIT = 3    # run_scenario's exit code for a run that ended in an unexpected fault state


def fault_verdict(scenario: Scenario, end_state: str, fault_kinds) -> tuple[int, str]:
    """(exit code, one line) of how a run ended, judged against scenario.expect_faults.

    0 for a run without faults or whose faults are all expected; FAULT_EXIT otherwise.
    """
    kinds = list(dict.fromkeys(fault_kinds))
    if not kinds and end_state == 'ended normally':
        return 0, f'{scenario.name}: ended normally'
    unexpected = [k for k in kinds if k not in scenario.expect_faults]
    if kinds and not unexpected:
        return 0, (f'{scenario.name}: {end_state}; expected by the scenario '
                   f'(expect_faults: {", ".join(scenario.expect_faults)})')
    which = ', '.join(unexpected) or 'safe state or protection active at the end'
    return FAULT_EXIT, f'{scenario.name}: {end_state}; unexpected: {which}'


def evaluate_metrics(scenario: Scenario, arrays: dict[str, np.ndarray]) -> dict[str, Any]:
    """Every metric the scenario names (in ``metrics`` or ``checks``); errors become strings."""
    return registry.evaluate(scenario.metrics, arrays, [c.metric for c in scenario.checks])


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


def write_report(scenario: Scenario, result, out_dir: Path, columns=None,
                 arrays: dict[str, np.ndarray] | None = None) -> dict[str, Any]:
    """Analyse a run: report.json, figures/*.png; returns the summary.

    The run's data: columns ({topic: {field: array}}), else the flat arrays of
    a headless run (:meth:`drive_bringup.headless.HeadlessResult.arrays`),
    else the columns of ``result.bag``.
    """
    from drive_analysis.bag_columns import load_columns
    from drive_analysis.figures import draw_all
    from drive_analysis.summary import json_safe, summarize

    out_dir = Path(out_dir)
    if columns is None:
        columns = columns_of(arrays) if arrays is not None else load_columns(str(result.bag))
    values = evaluate_metrics(scenario, flatten_columns(columns))
    rows = check_rows(scenario, values)
    figures = draw_all(columns, out_dir / 'figures')
    summary = {
        'scenario': scenario.name, 'seed_reference': scenario.seed_reference,
        'description': scenario.description, 'bag': str(result.bag) if result.bag else None,
        'sim_time': result.final_time, 'wall_time': result.wall_time,
        'samples_per_second': result.samples_per_second,
        'end_state': getattr(result, 'end_state', 'ended normally'),
        'fault_kinds': list(getattr(result, 'fault_kinds', ())),
        'metrics': values, 'checks': rows, 'analysis': summarize(columns),
        'figures': figures,
        'headline': {'scenario': scenario.name, 'sim_time_s': result.final_time,
                     'wall_time_s': round(result.wall_time, 2),
                     'samples_per_second': round(result.samples_per_second),
                     **values,
                     'checks_passed': f'{sum(r["pass"] for r in rows)}/{len(rows)}'},
    }
    summary = json_safe(summary)
    (out_dir / 'report.json').write_text(json.dumps(summary, indent=2))
    return summary
