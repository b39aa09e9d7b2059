"""Shared helpers of the closed-loop tests: run a shipped scenario headless, shortened.

``run_reduced(name, duration)`` loads ``drive_bringup/scenarios/<name>.yaml``
(validated, ``package://`` paths resolved), shortens it to ``duration`` [s]
(events after the new end are dropped), steps PlantCore + DtcCore with
:func:`drive_bringup.headless.run_headless` and returns the scenario, the
arrays dict and the wall time. Results are cached per (name, duration) so
several tests can assert on one run.
"""
from __future__ import annotations

import functools
import math
import time

from drive_analysis import registry
from drive_analysis.metrics import RATED_TORQUE_000
from drive_bringup.headless import run_headless
from drive_bringup.scenario import find_scenario, load_scenario

RATED_TORQUE = RATED_TORQUE_000
# 000 Appendix A motor (the plant's motor files): phase circuit inductance L - M,
# resistance, pole pairs, phase flat-top back-EMF constant K = lambda_f / p.
L_CIRCUIT = 1.4e-3 - 0.3125e-3      # H
R_PHASE = 0.315                     # ohm
POLE_PAIRS = 2
K_FLAT = 0.0573                     # V s/rad per electrical rad/s
K_TORQUE = 2 * POLE_PAIRS * K_FLAT  # N m/A, two-phase conduction (= 0.2292)
PEAK_CURRENT = 24.0                 # A, protection level
VDC_SIX = 40 * math.sqrt(2)
VDC_FOUR = 80 * math.sqrt(2)


def load(name: str):
    return load_scenario(find_scenario(name))


@functools.lru_cache(maxsize=None)
def run_reduced(name: str, duration: float):
    """(scenario, arrays, wall seconds) of scenario `name` run for `duration` s of sim time."""
    sc = load(name).shortened(duration)
    t0 = time.perf_counter()
    result = run_headless(sc)
    wall = time.perf_counter() - t0
    return sc, result.arrays(), wall


def metrics(name: str, duration: float, **overrides) -> dict[str, float]:
    """The scenario's `metrics:` evaluated on the reduced run; overrides replace option sets."""
    sc, arrays, _ = run_reduced(name, duration)
    spec = dict(sc.metrics)
    spec.update(overrides)
    return registry.evaluate(spec, arrays, [c.metric for c in sc.checks])


def check_scenario_file(name: str, seed_reference: str) -> None:
    """Shipped-scenario contract: name = stem, seed reference, description, computable checks."""
    path = find_scenario(name)
    sc = load_scenario(path)
    assert sc.name == path.stem == name
    assert seed_reference in sc.seed_reference
    assert len(sc.description) > 100
    assert sc.checks
    known = set(sc.metrics) | set(registry.metrics())
    for c in sc.checks:
        assert c.metric in known, f'{name}: check on unknown metric {c.metric}'
    for label, options in sc.metrics.items():
        assert (options or {}).get('metric', label) in registry.metrics(), label
    assert sc.node_parameters['dtc_controller']['backemf_table_path'].endswith('_backemf.csv')
