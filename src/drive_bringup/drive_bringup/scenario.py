"""Scenario files: schema, loading and validation (no rclpy).

A scenario (YAML) names the nodes' parameters, the run length, timed events, what to record,
the metrics and figures to report and the seed values it reproduces (docs/scenarios.md "The
scenario file"). Every mistake is a ``ScenarioError`` naming the file, the key path and the
reason; node parameters are validated against the schema the node itself declares.
"""
from __future__ import annotations

import importlib
import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import yaml

from drive_common.parameters import ParameterError, ParameterSchema
from drive_common.telemetry import DEFAULT_LIVE_PERIOD
from drive_common.uris import resolve_path

NODE_SCHEMAS = {
    'plant': ('bldc_plant_sim.parameters', 'PLANT_SCHEMA'),
    'dtc_controller': ('dtc_controller.parameters', 'DTC_SCHEMA'),
    'pfc_controller': ('pfc_controller.parameters', 'PFC_SCHEMA'),
}
CONTROLLER_KEYS = {'package', 'executable', 'core', 'node_name', 'parameters'}
TOP_KEYS = {'name', 'description', 'seed_reference', 'duration', 'nodes', 'events', 'record',
            'metrics', 'figures', 'checks', 'expect_faults'}


class ScenarioError(ValueError):
    """A scenario file is malformed; the message names file, key and reason."""


def _resolve_paths(params: dict) -> dict:
    """package:// values as file paths (:func:`drive_common.uris.resolve_path`)."""
    try:
        return {k: resolve_path(v) if isinstance(v, str) else v for k, v in params.items()}
    except FileNotFoundError as exc:
        raise ScenarioError(str(exc)) from exc


def node_schema(node: str) -> ParameterSchema:
    module, attr = NODE_SCHEMAS[node]
    return getattr(importlib.import_module(module), attr)


@dataclass(frozen=True)
class ControllerProgram:
    """A scenario's own drive controller (``nodes.controller``): what runs, and its core."""

    package: str
    executable: str
    core: str                           # 'module:Class', a drive_common.controller_api.ControllerCore
    node_name: str

    def core_class(self) -> type:
        """The core class (ValueError naming the problem if it cannot be imported)."""
        from drive_common.controller_api import check_core_class
        module, _, attr = self.core.partition(':')
        try:
            core_class = getattr(importlib.import_module(module), attr)
            check_core_class(core_class)
        except (ImportError, AttributeError, TypeError) as exc:
            raise ValueError(f'core {self.core!r}: {exc}') from exc
        return core_class


@dataclass(frozen=True)
class Event:
    time: float                         # s
    node: str
    parameters: dict[str, Any]


@dataclass(frozen=True)
class Check:
    metric: str
    label: str
    seed: float | None = None
    tolerance: float | None = None
    minimum: float | None = None
    maximum: float | None = None

    def evaluate(self, value: float | None) -> bool:
        """Whether value passes: within seed ± tolerance and the bounds (None and NaN fail)."""
        return (value is not None and not (isinstance(value, float) and math.isnan(value))
                and (self.seed is None or abs(value - self.seed) <= self.tolerance)
                and (self.minimum is None or value >= self.minimum)
                and (self.maximum is None or value <= self.maximum))

    def criterion(self) -> str:
        """The pass criterion as text: 'seed ± tolerance', '≥ min', '≤ max', comma separated."""
        parts = [f'{self.seed:g} ± {self.tolerance:g}' if self.seed is not None else '',
                 f'≥ {self.minimum:g}' if self.minimum is not None else '',
                 f'≤ {self.maximum:g}' if self.maximum is not None else '']
        return ', '.join(part for part in parts if part)


@dataclass
class Scenario:
    path: Path
    name: str
    duration: float
    node_parameters: dict[str, dict[str, Any]]     # node -> full validated snapshot
    overrides: dict[str, dict[str, Any]]           # node -> parameters the file set
    events: list[Event] = field(default_factory=list)
    description: str = ''
    seed_reference: str = ''
    record: bool = True
    record_topics: list[str] = field(default_factory=list)
    record_lockstep: bool = False       # also record the raw lockstep topics
    record_viewer_period: float | None = DEFAULT_LIVE_PERIOD   # s; None: no viewer topics
    metrics: dict[str, dict] = field(default_factory=dict)
    figures: list[str] = field(default_factory=list)
    checks: list[Check] = field(default_factory=list)
    controller: ControllerProgram | None = None    # nodes.controller, else None
    expect_faults: tuple[str, ...] = ()            # fault kind labels the run is meant to produce

    def schema(self, node: str) -> ParameterSchema:
        """The parameter schema of one of the scenario's nodes."""
        if node == 'controller' and self.controller is not None:
            return self.controller.core_class().SCHEMA
        return node_schema(node)

    @property
    def nodes(self) -> list[str]:
        return list(self.node_parameters)

    def with_parameters(self, source: str, sections: dict[str, dict[str, Any]]) -> 'Scenario':
        """A copy whose nodes also take the values of a ROS 2 parameter file.

        sections: :func:`drive_common.parameter_files.read_params_file` of
        ``source``; a wildcard (``/**``) value applies to the nodes that have
        the parameter, a node's own section must name its parameters.
        """
        from drive_common.parameter_files import WILDCARDS, node_of, parameters_for
        unknown = [k for k in sections if k not in WILDCARDS and node_of(k) not in self.nodes]
        if unknown:
            raise ScenarioError(f'{source}: {unknown[0]}: not a node of scenario {self.name} '
                                f'({", ".join(self.nodes)})')
        overrides, snapshots = dict(self.overrides), dict(self.node_parameters)
        for node in self.nodes:
            schema = self.schema(node)
            values = parameters_for(node, sections, known=schema)
            merged = dict(self.overrides[node], **values)
            try:
                snapshots[node] = schema.resolve(merged)
            except ParameterError as exc:
                raise ScenarioError(f'{source}: {node}: {exc}') from exc
            overrides[node] = {k: snapshots[node][k] for k in merged}   # typed, paths resolved
        return replace(self, overrides=overrides, node_parameters=snapshots)

    def shortened(self, duration: float) -> 'Scenario':
        """A copy that ends at ``duration`` s (0 < duration <= self.duration); events at or
        after the new end are dropped (an event at the end time would never apply)."""
        if not 0.0 < duration <= self.duration:
            raise ScenarioError(f'{self.path}: duration: {duration} s is outside '
                                f'(0, {self.duration} s]')
        return self.with_duration(duration)

    def with_duration(self, duration: float) -> 'Scenario':
        """A copy that runs ``duration`` s (> 0, shorter or longer: studies and benchmarks);
        events at or after the end are dropped."""
        if not duration > 0.0:
            raise ScenarioError(f'{self.path}: duration: {duration} s must be > 0')
        return replace(self, duration=duration, events=[e for e in self.events if e.time < duration])


TOPIC_NAME = re.compile(r'/?[A-Za-z_~][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*')


def _known_metric(path: Path, key: str, name) -> None:
    from drive_analysis.registry import lookup
    if not isinstance(name, str):
        raise _fail(path, key, f'expected a metric name, got {name!r}')
    try:
        lookup(name)
    except KeyError as exc:
        raise _fail(path, key, exc.args[0]) from exc


def _check_metrics(path: Path, metrics: dict) -> None:
    """Each ``metrics`` entry is a mapping naming a known metric (its ``metric`` option, else its key)."""
    for name, options in metrics.items():
        options = _mapping(options, path, f'metrics.{name}')
        _known_metric(path, f'metrics.{name}', options.get('metric', name))


def _fail(path: Path, key: str, reason: str) -> ScenarioError:
    return ScenarioError(f'{path}: {key}: {reason}')


def _mapping(value, path: Path, key: str) -> dict:
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise _fail(path, key, f'expected a mapping, got {type(value).__name__}')
    return value


def _entry(value, path: Path, key: str, allowed, required=()) -> dict:
    """value as a mapping (None: {}) of the allowed keys (listed in this order) with every required one."""
    value = _mapping(value, path, key)
    prefix = '' if key == '(top level)' else key + '.'
    extra = sorted(set(value) - set(allowed))
    if extra:
        raise _fail(path, f'{prefix}{extra[0]}', 'unknown key (allowed: ' + ', '.join(allowed) + ')')
    for req in required:
        if req not in value:
            raise _fail(path, prefix + req, 'required key missing')
    return value


def _list(value, path: Path, key: str) -> list:
    if value is None:
        return []
    if not isinstance(value, list):
        raise _fail(path, key, f'expected a list, got {type(value).__name__}')
    return value


def _number(value, path: Path, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise _fail(path, key, f'expected a finite number, got {value!r}')
    return float(value)


def read_named_file(path: Path, allowed: set[str], required: tuple[str, ...]) -> tuple[dict, str]:
    """(top-level mapping, its name) of a scenario or study file: YAML, no unknown or missing
    key, a ``name`` without "/"; ScenarioError naming file, key and reason."""
    try:
        raw = yaml.safe_load(path.read_text())
    except OSError as exc:
        raise ScenarioError(f'{path}: cannot read: {exc.strerror}') from exc
    except yaml.YAMLError as exc:
        raise ScenarioError(f'{path}: not valid YAML: {exc}') from exc
    raw = _entry(raw, path, '(top level)', sorted(allowed), ('name', *required))
    name = raw['name']
    if not isinstance(name, str) or not name or '/' in name:
        raise _fail(path, 'name', 'expected a non-empty string without "/"')
    return raw, name


def load_scenario(path: str | Path) -> Scenario:
    """Load and validate a scenario file; raise ScenarioError naming what is wrong."""
    path = Path(path)
    raw, name = read_named_file(path, TOP_KEYS, ('duration', 'nodes'))
    duration = _number(raw['duration'], path, 'duration')
    if duration <= 0.0:
        raise _fail(path, 'duration', 'must be > 0 s')

    nodes = _mapping(raw['nodes'], path, 'nodes')
    if 'plant' not in nodes:
        raise _fail(path, 'nodes.plant', 'required: the plant is the time master')
    snapshots, overrides = {}, {}
    controller = _controller_program(path, nodes)
    schemas = {}
    for node, spec in nodes.items():
        key = f'nodes.{node}'
        if node not in NODE_SCHEMAS and node != 'controller':
            raise _fail(path, key, 'unknown node (allowed: ' + ', '.join(NODE_SCHEMAS)
                        + ', controller)')
        spec = _entry(spec, path, key, sorted(CONTROLLER_KEYS) if node == 'controller' else ('parameters',))
        try:
            schemas[node] = controller.core_class().SCHEMA if node == 'controller' else node_schema(node)
        except ValueError as exc:
            raise _fail(path, f'{key}.core', str(exc)) from exc
        params = _resolve_paths(_mapping(spec.get('parameters'), path, f'{key}.parameters'))
        try:
            snapshots[node] = schemas[node].resolve(params)
        except ParameterError as exc:
            raise _fail(path, f'{key}.parameters', str(exc)) from exc
        overrides[node] = dict(params)

    events = []
    for i, ev in enumerate(_list(raw.get('events'), path, 'events')):
        key = f'events[{i}]'
        ev = _entry(ev, path, key, ('time', 'node', 'parameters'), ('time', 'node', 'parameters'))
        t = _number(ev['time'], path, f'{key}.time')
        if not 0.0 <= t < duration:
            raise _fail(path, f'{key}.time', f'{t} s is outside [0, duration = {duration} s)')
        node = ev['node']
        if not isinstance(node, str) or node not in snapshots:
            raise _fail(path, f'{key}.node', f'{node!r} is not a node of this scenario')
        params = _resolve_paths(_mapping(ev['parameters'], path, f'{key}.parameters'))
        if not params:
            raise _fail(path, f'{key}.parameters', 'no parameters to change')
        try:
            schemas[node].validate_changes(snapshots[node], params)
            unknown_params = sorted(set(params) - set(schemas[node].names()))
            if unknown_params:
                raise ParameterError('unknown parameter(s): ' + ', '.join(unknown_params))
        except ParameterError as exc:
            raise _fail(path, f'{key}.parameters', str(exc)) from exc
        events.append(Event(t, node, dict(params)))
    if [e.time for e in events] != sorted(e.time for e in events):
        raise _fail(path, 'events', 'events must be in time order')

    record = _entry(raw.get('record'), path, 'record', ('enabled', 'topics', 'lockstep', 'viewer_period'))
    viewer_period = record.get('viewer_period', DEFAULT_LIVE_PERIOD)
    if viewer_period is False:
        viewer_period = None
    elif isinstance(viewer_period, bool) or not isinstance(viewer_period, (int, float)) \
            or not 0.0 <= viewer_period <= 1.0:
        raise _fail(path, 'record.viewer_period', f'expected s in [0, 1] or false, got {viewer_period!r}')
    enabled = record.get('enabled', True)
    lockstep = record.get('lockstep', False)
    for key, value in (('enabled', enabled), ('lockstep', lockstep)):
        if not isinstance(value, bool):
            raise _fail(path, f'record.{key}', f'expected true or false, got {value!r}')
    topics = record.get('topics') or []
    if not isinstance(topics, list) or not all(isinstance(t, str) for t in topics):
        raise _fail(path, 'record.topics', 'expected a list of topic names')
    for i, topic in enumerate(topics):
        if not TOPIC_NAME.fullmatch(topic):
            raise _fail(path, f'record.topics[{i}]', f'{topic!r} is not a valid ROS topic name')

    metrics = _mapping(raw.get('metrics'), path, 'metrics')
    _check_metrics(path, metrics)
    figures = raw.get('figures') or []
    if not isinstance(figures, list) or not all(isinstance(f, str) for f in figures):
        raise _fail(path, 'figures', 'expected a list of figure names')
    from drive_analysis.figures import ALL_FIGURES
    for i, figure in enumerate(figures):
        if figure not in ALL_FIGURES:
            raise _fail(path, f'figures[{i}]', f'unknown figure {figure!r} (known: '
                        + ', '.join(ALL_FIGURES) + ')')

    checks = []
    for i, ch in enumerate(_list(raw.get('checks'), path, 'checks')):
        key = f'checks[{i}]'
        ch = _entry(ch, path, key, ('metric', 'seed', 'tolerance', 'min', 'max', 'label'), ('metric',))
        seed, tol, lo, hi = (_number(ch[n], path, f'{key}.{n}') if n in ch else None
                             for n in ('seed', 'tolerance', 'min', 'max'))
        if (seed is None) != (tol is None):
            raise _fail(path, key, 'seed and tolerance go together')
        if seed is None and lo is None and hi is None:
            raise _fail(path, key, 'needs seed + tolerance, or min / max')
        if tol is not None and tol < 0.0:
            raise _fail(path, f'{key}.tolerance', f'must be >= 0, got {tol}')
        if lo is not None and hi is not None and lo > hi:
            raise _fail(path, key, f'min {lo} is above max {hi}')
        if not isinstance(ch['metric'], str) or ch['metric'] not in metrics:
            _known_metric(path, f'{key}.metric', ch['metric'])
        checks.append(Check(ch['metric'], str(ch.get('label', ch['metric'])), seed, tol, lo, hi))

    expect_faults = _fault_kinds(raw.get('expect_faults'), path)
    return Scenario(path=path, name=name, duration=duration, node_parameters=snapshots,
                    overrides=overrides, events=events,
                    description=str(raw.get('description', '')),
                    seed_reference=str(raw.get('seed_reference', '')),
                    record=enabled, record_topics=list(topics), record_lockstep=lockstep,
                    record_viewer_period=None if viewer_period is None else float(viewer_period),
                    metrics=metrics, figures=list(figures), checks=checks, controller=controller,
                    expect_faults=expect_faults)


def _fault_kinds(value, path: Path) -> tuple[str, ...]:
    """expect_faults: a list of fault kind labels (FaultKind), validated."""
    if value is None:
        return ()
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise _fail(path, 'expect_faults', 'expected a list of fault kinds')
    from bldc_plant_sim.core.faults import fault_kind
    for i, name in enumerate(value):
        try:
            fault_kind(name)
        except ValueError as exc:
            raise _fail(path, f'expect_faults[{i}]', str(exc)) from None
    return tuple(fault_kind(v).label for v in value)


def _controller_program(path: Path, nodes: dict) -> ControllerProgram | None:
    """nodes.controller as a ControllerProgram (None without one); ScenarioError if malformed."""
    if 'controller' not in nodes:
        return None
    if 'dtc_controller' in nodes:
        raise _fail(path, 'nodes.controller', 'a scenario has either dtc_controller or its own '
                    'controller (both answer drive/measurement)')
    spec = _mapping(nodes['controller'], path, 'nodes.controller')
    values = {}
    for name in ('package', 'executable', 'core', 'node_name'):
        value = spec.get(name, spec.get('executable') if name == 'node_name' else None)
        if not isinstance(value, str) or not value:
            raise _fail(path, f'nodes.controller.{name}', 'required: a non-empty string')
        values[name] = value
    if values['core'].count(':') != 1:
        raise _fail(path, 'nodes.controller.core', f'expected module:Class, got {values["core"]!r}')
    return ControllerProgram(**values)


def shipped_dir(kind: str = 'scenarios') -> Path:
    """The shipped files of a kind ('scenarios', 'studies'): the source tree (symlink/develop
    installs), else share/drive_bringup/<kind>."""
    source = Path(__file__).resolve().parents[1] / kind
    if source.is_dir():
        return source
    from ament_index_python.packages import get_package_share_directory
    return Path(get_package_share_directory('drive_bringup')) / kind


def find_shipped(name_or_path: str, kind: str = 'scenarios') -> Path:
    """A path as given, or a shipped file's name looked up in shipped_dir(kind); ScenarioError
    naming the known ones otherwise."""
    path = Path(name_or_path)
    if path.suffix in ('.yaml', '.yml') or path.exists():
        return path
    candidate = shipped_dir(kind) / f'{name_or_path}.yaml'
    if not candidate.exists():
        known = sorted(p.stem for p in shipped_dir(kind).glob('*.yaml'))
        raise ScenarioError(f'no {kind[:-1].replace("ie", "y")} {name_or_path!r} '
                            f'(known: {", ".join(known)})')
    return candidate


scenario_dir, find_scenario = shipped_dir, find_shipped      # the shipped scenarios (the default kind)
