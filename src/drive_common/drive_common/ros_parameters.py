"""Bind a :class:`~drive_common.parameters.ParameterSchema` to an rclpy node.

Declares every parameter once with a ParameterDescriptor (type, range,
description with unit) and installs one set-parameters callback that
validates through the schema; a whole number given for a double (array)
parameter is taken as that double (:func:`as_declared_type`). A rejected
change keeps the old value and returns the reason to the caller
(``ros2 param set`` prints it). Accepted
changes are handed to ``on_change`` as a full new snapshot; the node swaps
it in at its next sample boundary.

With ``sim_time``, the node's ``/parameter_events`` carry sim time instead
of the node's (wall) clock (:class:`SimStampedEvents`; docs/architecture.md
"Bags").
"""
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
    """params with a whole number given for a double (array) parameter as that double (array).

    ROS types ``-p run_until:=20`` or ``ros2 param set /plant load.torque 1`` as
    an integer, which rclpy refuses for a parameter declared double; the number
    means the same, so it is taken (a value of any other type is still refused).
    """
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
    """Stands in for a node's ``/parameter_events`` publisher: stamps each event with sim time.

    rclpy (Jazzy) stamps a ParameterEvent with ``node._clock.now()`` in
    ``Node._set_parameters_atomically_common``, just before it calls
    ``node._parameter_event_publisher.publish``; nothing else uses that
    publisher. Re-stamping the event here touches only parameter events: the
    node's clock stays as it is, so timers, the action server's goal stamps,
    the time source and every other thread never see a borrowed time (which
    swapping ``node._clock`` for the duration of a set would risk). The result
    is what rclpy gives a node that runs on sim time (``use_sim_time``); the
    drive nodes make sim time, so they cannot take it from /clock.

    sim_time: the node's sim time, in s or as the builtin_interfaces/Time of
        a sample (the plant: its current time; a controller: the stamp of the
        last sample it answered), or None before it has one (the event keeps
        rclpy's stamp, the node's clock).
    """

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

    node: the rclpy node.
    schema: the node's ParameterSchema.
    on_change: called with the new full snapshot before it is accepted; it
        may refuse by raising ParameterError (the old values are kept).
    is_running: returns True while runtime=False parameters must be refused.
    sim_time: the node's sim time or None (see :class:`SimStampedEvents`);
        given, every parameter event after the declaration carries it. The
        declaration's own events (and rclpy's ``use_sim_time``) keep the
        node's clock: the node has no sim time before its state exists.
    """

    def __init__(self, node, schema: ParameterSchema,
                 on_change: Callable[[dict[str, Any]], None] | None = None,
                 is_running: Callable[[], bool] = lambda: False,
                 sim_time: Callable[[], SimTime] | None = None) -> None:
        self._node = node
        self._schema = schema
        self._on_change = on_change
        self._is_running = is_running
        # Start-up overrides (-p, --params-file) as the declared type; rclpy has no public
        # hook before a declaration takes its override (pre-set callbacks come later).
        overrides = getattr(node, '_parameter_overrides', None)
        if isinstance(overrides, dict):
            overrides.update({p.name: p for p in as_declared_type(schema, list(overrides.values()))})
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

    def __getitem__(self, name: str) -> Any:
        return self.values[name]

    def add_pre_set(self, hook: Callable[[list], list]) -> None:
        """Run hook(parameters) -> parameters on every change before it is validated, after
        whole numbers became doubles. rclpy joins the lists its own pre-set callbacks return
        (each sees the original list), so a node chains its hooks here instead."""
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

