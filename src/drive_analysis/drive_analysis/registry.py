"""The one metric registry: name -> ``function(arrays, **options) -> float``, and the one evaluate path.

Every public function defined in a module of :data:`METRIC_MODULES` is a
metric under its own name (helpers are private or live in
:mod:`drive_analysis.arrays`); a name defined twice is refused. A scenario's
``metrics`` / ``checks`` name metrics, or aliases ``label: {metric: <name>,
...options}`` (one function, several option sets).
"""
from __future__ import annotations

import importlib
import inspect
from typing import Any, Callable

METRIC_MODULES = ('drive_analysis.metrics.two_phase', 'drive_analysis.metrics.three_phase',
                  'drive_analysis.metrics.ripple', 'drive_analysis.metrics.pfc')
_REGISTRY: dict[str, Callable[..., float]] = {}

__all__ = ['METRIC_MODULES', 'metrics', 'lookup', 'evaluate']


def metrics() -> dict[str, Callable[..., float]]:
    """Every metric by name (the modules are imported on first use)."""
    if not _REGISTRY:
        found: dict[str, Callable[..., float]] = {}
        for module_name in METRIC_MODULES:
            module = importlib.import_module(module_name)
            for name, fn in vars(module).items():
                if name.startswith('_') or not inspect.isfunction(fn) or fn.__module__ != module_name:
                    continue
                if name in found:
                    raise RuntimeError(f'metric {name!r} defined in {found[name].__module__} and {module_name}')
                found[name] = fn
        _REGISTRY.update(found)
    return _REGISTRY


def lookup(name: str) -> Callable[..., float]:
    """The metric called ``name``; KeyError naming it otherwise."""
    try:
        return metrics()[name]
    except KeyError:
        raise KeyError(f'no metric named {name!r} in {", ".join(METRIC_MODULES)}') from None


def evaluate(spec: dict[str, dict | None], arrays: dict, names=()) -> dict[str, Any]:
    """Evaluate ``spec`` ({label: options}, options may hold ``metric: <name>``) and ``names`` (default options).

    Returns {label: float}; a metric that fails gives ``'error: <type>: <reason>'`` instead,
    so one bad metric does not hide the others.
    """
    todo = list(spec.items()) + [(n, None) for n in names if n not in spec]
    values: dict[str, Any] = {}
    for label, options in todo:
        options = dict(options or {})
        name = options.pop('metric', label)
        try:
            values[label] = float(lookup(name)(arrays, **options))
        except Exception as exc:  # noqa: BLE001 - reported in the value
            values[label] = f'error: {type(exc).__name__}: {exc}'
    return values
