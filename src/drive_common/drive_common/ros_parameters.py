"""Bind a :class:`~drive_common.parameters.ParameterSchema` to an rclpy node: declared with
descriptors, every change validated by the schema (a rejected one keeps the old value and
returns the reason), accepted ones handed to ``on_change`` as a full snapshot."""
from __future__ import annotations

from typing import Any, Callable, Union

from builtin_interfaces.msg import Time
from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                ParameterType, SetParametersResult)

from drive_common.conversions import time_msg
from drive_common.parameters import ParameterError, ParameterSchema, ParameterSpec

SimTime = Union[float, Time, None]   # a node's sim time: s, a sample's stamp, or none yet

_ROS_TYPES = {
    bool: ParameterType.PARAMETER_BOOL,
    int: ParameterType.PARAMETER_INTEGER,
    float: ParameterType.PARAMETER_DOUBLE,
    str: ParameterType.PARAMETER_STRING,
}


def _ros_type(spec: ParameterSpec) -> int:
    if spec.value_type is list:
        item = type(spec.default[0]) if spec.default else float
        return (ParameterType.PARAMETER_STRING_ARRAY if item is str
                else ParameterType.PARAMETER_DOUBLE_ARRAY)
    return _ROS_TYPES[spec.value_type]


def constraints(spec: ParameterSpec) -> str:
    """The descriptor's additional_constraints: allowed values, element range, length, unit."""
    parts = []
    if spec.choices:
        parts.append('one of: ' + ', '.join(str(c) for c in spec.choices))
    if spec.value_type is list:
        if spec.length is not None:
            parts.append(f'{spec.length} values')
        if spec.min_value is not None or spec.max_value is not None:
            parts.append(f'each in [{spec.min_value}, {spec.max_value}]')
    if spec.unit:
        parts.append(f'unit: {spec.unit}')
    return '; '.join(parts)


def as_declared_type(schema: ParameterSchema, params: list) -> list:
    """params with a whole number given for a double (array) parameter as that double (array)
    (``-p run_until:=20`` arrives as an integer, which rclpy refuses)."""
    from rclpy.parameter import Parameter
    out = []
    for param in params:
        want = _ros_type(schema[param.name]) if param.name in schema else None
        if want == ParameterType.PARAMETER_DOUBLE and param.type_ == Parameter.Type.INTEGER:
            param = Parameter(param.name, Parameter.Type.DOUBLE, float(param.value))
        elif (want == ParameterType.PARAMETER_DOUBLE_ARRAY
              and param.type_ == Parameter.Type.INTEGER_ARRAY):
            param = Parameter(param.name, Parameter.Type.DOUBLE_ARRAY, [float(v) for v in param.value])
        out.append(param)
    return out


def descriptor(spec: ParameterSpec) -> ParameterDescriptor:
    """ParameterDescriptor carrying the spec's type, text, range, choices and read-only flag."""
    desc = ParameterDescriptor(
        name=spec.name,
        type=_ros_type(spec),
        description=spec.describe(),
        additional_constraints=constraints(spec),
        read_only=spec.read_only,
    )
    lo, hi = spec.min_value, spec.max_value
    if spec.value_type is float and lo is not None and hi is not None:
        desc.floating_point_range = [FloatingPointRange(from_value=float(lo), to_value=float(hi), step=0.0)]
    elif spec.value_type is int and lo is not None and hi is not None:
        desc.integer_range = [IntegerRange(from_value=int(lo), to_value=int(hi), step=1)]
    return desc


class SimStampedEvents:
    """Stands in for a node's ``/parameter_events`` publisher: stamps each event with sim_time()
    (s or a Time; None: rclpy's stamp kept), leaving the node's clock alone."""

    def __init__(self, publisher, sim_time: Callable[[], SimTime]) -> None:
        self._publisher = publisher
        self._sim_time = sim_time

    def publish(self, event) -> None:
        now = self._sim_time()
        if now is not None:
            event.stamp = now if isinstance(now, Time) else time_msg(now)
        self._publisher.publish(event)

    def __getattr__(self, name: str):
        return getattr(self._publisher, name)

    @classmethod
    def install(cls, node, sim_time: Callable[[], SimTime]) -> None:
        """Wrap node's parameter event publisher (refuses an rclpy without it: no silent wall stamp)."""
        publisher = getattr(node, '_parameter_event_publisher', None)
        if publisher is None or not hasattr(publisher, 'publish'):
            raise RuntimeError(f'{node.get_name()}: this rclpy has no Node._parameter_event_publisher; '
                               'parameter events cannot be stamped with sim time')
        node._parameter_event_publisher = cls(publisher, sim_time)


class SchemaParameters:
    """Declared parameters of one node, validated by its schema.

    on_change(snapshot): may refuse with ParameterError; is_running(): True while runtime=False
    parameters are refused; sim_time: stamps later parameter events (:class:`SimStampedEvents`);
    start_values(values) -> values: what to declare instead of the start-up values (a motor file's
    values merged in), so that start-up publishes no parameter change.
    """

    def __init__(self, node, schema: ParameterSchema,
                 on_change: Callable[[dict[str, Any]], None] | None = None,
                 is_running: Callable[[], bool] = lambda: False,
                 sim_time: Callable[[], SimTime] | None = None,
                 start_values: Callable[[dict[str, Any]], dict[str, Any]] | None = None) -> None:
        self._node = node
        self._schema = schema
        self._on_change = on_change
        self._is_running = is_running
        # Start-up overrides as the declared type (rclpy has no public hook for them).
        overrides = getattr(node, '_parameter_overrides', None)
        if isinstance(overrides, dict):
            overrides.update({p.name: p for p in as_declared_type(schema, list(overrides.values()))})
            if start_values is not None:
                overrides.update(self._start_overrides(overrides, start_values))
        self._pre_set: list[Callable[[list], list]] = []
        node.add_pre_set_parameters_callback(self._before_set)
        declared = node.declare_parameters(
            '', [(s.name, s.default, descriptor(s)) for s in schema.specs])
        initial = {p.name: p.value for p in declared}
        try:
            self.values = schema.validate_changes(schema.defaults(), initial)
        except ParameterError as exc:
            raise ParameterError(f'{node.get_name()}: invalid start-up parameter: {exc}') from exc
        node.add_on_set_parameters_callback(self._on_set)
        if sim_time is not None:
            SimStampedEvents.install(node, sim_time)

    def _start_overrides(self, overrides: dict, start_values: Callable) -> dict:
        """The overrides that make the declared values start_values(the start-up values)."""
        from rclpy.parameter import Parameter
        given = {n: p.value for n, p in overrides.items() if n in self._schema}
        try:
            requested = self._schema.validate_changes(self._schema.defaults(), given)
        except ParameterError:
            return {}                     # refused below, with the start-up error message
        return {n: Parameter(n, Parameter.Type(_ros_type(self._schema[n])),
                             list(v) if isinstance(v, tuple) else v)
                for n, v in start_values(requested).items() if v != requested[n]}

    def __getitem__(self, name: str) -> Any:
        return self.values[name]

    def add_pre_set(self, hook: Callable[[list], list]) -> None:
        """Run hook(parameters) -> parameters on every change before validation (chained here:
        rclpy's own pre-set callbacks each see the original list)."""
        self._pre_set.append(hook)

    def _before_set(self, params: list) -> list:
        params = as_declared_type(self._schema, params)
        for hook in self._pre_set:
            params = hook(params)
        return params

    def _on_set(self, params) -> SetParametersResult:
        changes = {p.name: p.value for p in params if p.name in self._schema}
        if not changes:
            return SetParametersResult(successful=True)
        try:
            snapshot = self._schema.validate_changes(self.values, changes, running=self._is_running())
            if self._on_change is not None:
                self._on_change(dict(snapshot))  # may refuse with ParameterError
        except ParameterError as exc:
            self._node.get_logger().warning(f'parameter change rejected: {exc}')
            return SetParametersResult(successful=False, reason=str(exc))
        self.values = snapshot
        return SetParametersResult(successful=True)

