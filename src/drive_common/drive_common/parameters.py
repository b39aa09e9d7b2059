"""Node parameter schemas: declared once, validated in one place (no rclpy).

The same :class:`ParameterSchema` is declared by the node (:mod:`drive_common.ros_parameters`)
and validates scenario files and the headless runner.
"""
from __future__ import annotations

import array
import math
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Iterable, Mapping

from drive_common.uris import resolve_path

ValueType = type  # one of bool, int, float, str, list (of float / str)


class ParameterError(ValueError):
    """A parameter value was rejected; the message says which and why."""


@dataclass(frozen=True)
class ParameterSpec:
    """One node parameter: its type is the default's (list: of floats or strings); SI unit;
    inclusive range (None: open); runtime False: changes only while held; read_only: set at start."""

    name: str
    default: Any
    description: str
    unit: str = ''
    min_value: float | None = None
    max_value: float | None = None
    choices: tuple = ()
    runtime: bool = True
    length: int | None = None
    read_only: bool = False

    @property
    def value_type(self) -> ValueType:
        return type(self.default)

    def limits(self) -> list[str]:
        """What bounds a value, in words: range, choices (unit and runtime flags not included)."""
        out = []
        if self.min_value is not None or self.max_value is not None:
            lo = '-inf' if self.min_value is None else self.min_value
            hi = 'inf' if self.max_value is None else self.max_value
            out.append(f'range [{lo}, {hi}]')
        if self.choices:
            out.append('one of ' + ', '.join(str(c) for c in self.choices))
        return out

    def describe(self) -> str:
        """Human text for the ROS descriptor: description, unit, range."""
        parts = [self.description]
        if self.unit:
            parts.append(f'[{self.unit}]')
        if self.choices:
            parts.append('one of: ' + ', '.join(str(c) for c in self.choices))
        if self.read_only:
            parts.append('(read-only: set at start)')
        elif not self.runtime:
            parts.append('(changes only while the simulation is held)')
        return ' '.join(parts)

    def coerce(self, value: Any) -> Any:
        """Return value converted to this parameter's type, or raise ParameterError."""
        want = self.value_type
        if want is bool:
            if isinstance(value, bool):
                return value
            raise ParameterError(f'{self.name}: expected a bool, got {value!r}')
        if want is int:
            if isinstance(value, bool) or not isinstance(value, int):
                raise ParameterError(f'{self.name}: expected an integer, got {value!r}')
            return int(value)
        if want is float:
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ParameterError(f'{self.name}: expected a number, got {value!r}')
            return float(value)
        if want is str:
            if not isinstance(value, str):
                raise ParameterError(f'{self.name}: expected a string, got {value!r}')
            try:
                return resolve_path(value)      # package://<pkg>/<path>: the file it names
            except FileNotFoundError as exc:
                raise ParameterError(f'{self.name}: {exc}') from None
        if want is list:
            # array.array: what rclpy's parameter service delivers for double arrays
            if not isinstance(value, (list, tuple, array.array)):
                raise ParameterError(f'{self.name}: expected a list, got {value!r}')
            item_type = type(self.default[0]) if self.default else float
            for item in value:
                if item_type is float and (isinstance(item, bool) or not isinstance(item, (int, float))):
                    raise ParameterError(f'{self.name}: expected numbers, got {item!r}')
                if item_type is str and not isinstance(item, str):
                    raise ParameterError(f'{self.name}: expected strings, got {item!r}')
            return [float(item) for item in value] if item_type is float else list(value)
        raise ParameterError(f'{self.name}: unsupported parameter type {want.__name__}')

    def check(self, value: Any) -> Any:
        """Coerce and range-check value; return the clean value or raise ParameterError."""
        value = self.coerce(value)
        if isinstance(value, float) and not math.isfinite(value):
            raise ParameterError(f'{self.name}: must be finite, got {value!r}')
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            if self.min_value is not None and value < self.min_value:
                raise ParameterError(
                    f'{self.name}: {value} is below the minimum {self.min_value} {self.unit}'.rstrip())
            if self.max_value is not None and value > self.max_value:
                raise ParameterError(
                    f'{self.name}: {value} is above the maximum {self.max_value} {self.unit}'.rstrip())
        if isinstance(value, list):
            if self.length is not None and len(value) != self.length:
                raise ParameterError(f'{self.name}: expected {self.length} values, got {len(value)}')
            for item in value:
                if isinstance(item, float):
                    if not math.isfinite(item):
                        raise ParameterError(f'{self.name}: values must be finite')
                    if self.min_value is not None and item < self.min_value:
                        raise ParameterError(f'{self.name}: {item} is below the minimum {self.min_value}')
                    if self.max_value is not None and item > self.max_value:
                        raise ParameterError(f'{self.name}: {item} is above the maximum {self.max_value}')
        if self.choices and value not in self.choices:
            raise ParameterError(
                f'{self.name}: {value!r} is not one of ' + ', '.join(repr(c) for c in self.choices))
        return value


CrossCheck = Callable[[Mapping[str, Any]], None]
"""Validates a whole parameter snapshot; raises ParameterError with a reason."""


@dataclass
class ParameterSchema:
    """The full parameter set of one node, plus cross-parameter checks."""

    specs: tuple[ParameterSpec, ...]
    cross_checks: tuple[CrossCheck, ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        names = [s.name for s in self.specs]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise ValueError(f'duplicate parameter names: {sorted(dup)}')
        self._by_name = {s.name: s for s in self.specs}
        for spec in self.specs:
            spec.check(spec.default)

    def __contains__(self, name: str) -> bool:
        return name in self._by_name

    def __getitem__(self, name: str) -> ParameterSpec:
        return self._by_name[name]

    def names(self) -> list[str]:
        return [s.name for s in self.specs]

    def defaults(self) -> dict[str, Any]:
        return {s.name: s.default for s in self.specs}

    def validate_changes(self, current: Mapping[str, Any], changes: Mapping[str, Any],
                         running: bool = False) -> dict[str, Any]:
        """The new full snapshot with changes applied (names not in the schema ignored), or
        ParameterError (also a runtime=False change while running)."""
        snapshot = dict(current)
        for name, value in changes.items():
            spec = self._by_name.get(name)
            if spec is None:
                continue
            clean = spec.check(value)
            if running and not spec.runtime and clean != current.get(name):
                raise ParameterError(
                    f'{name}: can only change while the simulation is held '
                    '(no Run goal active); value kept')
            snapshot[name] = clean
        for check in self.cross_checks:
            check(snapshot)
        return snapshot

    def resolve(self, overrides: Mapping[str, Any] | None = None,
                strict: bool = True) -> dict[str, Any]:
        """Defaults updated with overrides, validated (strict: an unknown name is an error)."""
        overrides = dict(overrides or {})
        if strict:
            unknown = sorted(set(overrides) - set(self._by_name))
            if unknown:
                raise ParameterError('unknown parameter(s): ' + ', '.join(unknown))
        return self.validate_changes(self.defaults(), overrides, running=False)


def schema(specs: Iterable[ParameterSpec], *cross_checks: CrossCheck, read_only: bool = False) -> ParameterSchema:
    """Shorthand constructor; read_only: every parameter is fixed at start."""
    return ParameterSchema(tuple(replace(s, read_only=True) if read_only else s for s in specs), tuple(cross_checks))
