"""Write your own drive controller: the public contract and a one-call ``main``.

A drive controller takes part in the plant's lockstep exactly as the
built-in ``dtc_controller`` does (docs/write_your_own_controller.md,
docs/architecture.md "Time and lockstep"): for every ``drive/measurement``
of step k it answers one ``drive/gate_command`` carrying step k, and may
publish a ``dtc/status``. Everything that controls lives in a ROS-free *core*
class (:class:`ControllerCore`); :func:`run_controller` wraps it in the node base
the built-ins use (:class:`drive_common.lockstep_controller.LockstepControllerNode`):
validated parameters, changes applied at the next sample boundary, a re-sent
measurement answered from the cache, a second graph in the domain refused. The
same core runs headless (``drive_bringup.headless``), giving the same trajectory.

This module imports no rclpy: a core module may import it.
"""
from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

from drive_common.parameters import ParameterError, ParameterSchema, ParameterSpec, schema
from drive_common.samples import (ALL_OFF, TOPOLOGY_FOUR_SWITCH, TOPOLOGY_SIX_SWITCH, DriveSample,
                                  GateSample)

__all__ = ['ALL_OFF', 'CheckedCore', 'ControllerCore', 'DriveSample', 'GateSample',
           'MalformedCommand', 'ParameterError', 'ParameterSchema', 'ParameterSpec',
           'TOPOLOGY_FOUR_SWITCH', 'TOPOLOGY_SIX_SWITCH', 'check_core_class', 'controller_node',
           'run_controller', 'schema']


@runtime_checkable
class ControllerCore(Protocol):
    """What a drive controller core provides (no rclpy).

    ``SCHEMA`` (class attribute): its :class:`ParameterSchema`; the node
        declares it (names, units, ranges, runtime flag) and scenario files
        are validated against it.
    ``__init__(params)``: build from a validated snapshot (every name of the
        schema); raise ParameterError / ValueError to refuse (the node then
        exits 2 naming the reason).
    ``update(sample)``: one sample: :class:`DriveSample` of step k ->
        (:class:`GateSample` of the same step k, status or None). The status
        is a ``DtcStatusSample`` (``dtc_controller.core.status``; fields the
        controller has no value for NaN/0) or None for no ``dtc/status``.
    ``reconfigure(params)``: a full new snapshot, applied from the next
        ``update`` on (a change arrives between samples, never inside one).
    ``check(params)`` (optional): validate a changed snapshot without
        building a core; without it the node builds a throw-away core.
    """

    SCHEMA: ParameterSchema

    def update(self, sample: DriveSample) -> tuple[GateSample, Any]: ...

    def reconfigure(self, params: dict[str, Any]) -> None: ...


def check_core_class(core_class: type) -> None:
    """TypeError naming what core_class lacks to be a :class:`ControllerCore`."""
    missing = [name for name in ('SCHEMA', 'update', 'reconfigure') if not hasattr(core_class, name)]
    if missing:
        raise TypeError(f'{core_class.__module__}.{core_class.__qualname__} is not a controller '
                        f'core: no {", ".join(missing)} (drive_common.controller_api.ControllerCore)')
    if not isinstance(core_class.SCHEMA, ParameterSchema):
        raise TypeError(f'{core_class.__qualname__}.SCHEMA is not a drive_common ParameterSchema')


class MalformedCommand(ValueError):
    """A core returned a command that must not be sent (the message names what is wrong)."""


def command_problem(command, step: int) -> str | None:
    """Why a core's answer to sample ``step`` is malformed, or None.

    The plant checks step and topology itself; a ``switch_on`` of another length
    than 6 cannot be checked there (serialization truncates a longer one to the
    message's bool[6] and refuses a shorter one), so it is checked here.
    """
    if not isinstance(command, GateSample):
        return f'update returned {type(command).__name__}, not a GateSample'
    switches = command.switch_on
    if len(switches) != 6 or not all(isinstance(s, bool) or type(s).__name__ == 'bool_' for s in switches):
        return f'switch_on must be 6 bools (SW1..SW6), got {switches!r}'
    if command.step != step:
        return f'command for step {command.step} answers the sample of step {step}'
    return None


class CheckedCore:
    """A core whose commands are checked before they are sent (:func:`command_problem`).

    A malformed command raises :class:`MalformedCommand` after ``report`` got its
    one-line reason: nothing is sent for that sample and the node answers no more
    (a crashed controller), so the plant times out and applies the safe state,
    naming the node on /diagnostics.
    """

    def __init__(self, core, report) -> None:
        self.core, self._report = core, report

    def update(self, sample):
        command, status = self.core.update(sample)
        problem = command_problem(command, sample.step)
        if problem is not None:
            self._report(f'malformed command, not sent: {problem}')
            raise MalformedCommand(problem)
        return command, status

    def reconfigure(self, params) -> None:
        self.core.reconfigure(params)

    def check(self, params):
        check = getattr(self.core, 'check', None)
        return check(params) if check is not None else type(self.core)(params)


def controller_node(core_class: type, node_name: str, *, status: bool = True, **kwargs):
    """The node :func:`run_controller` runs (also for tests that run it in-process)."""
    check_core_class(core_class)
    from drive_common import topics
    from drive_common.lockstep_controller import LockstepChannels, LockstepControllerNode
    from dtc_msgs.msg import DriveMeasurement, DtcStatus, DtcStatusBlock, GateCommand

    channels = LockstepChannels(DriveMeasurement, topics.DRIVE_MEASUREMENT, DriveSample,
                                GateCommand, topics.GATE_COMMAND,
                                DtcStatus if status else None, topics.DTC_STATUS,
                                DtcStatusBlock if status else None, topics.DTC_STATUS_BLOCK)
    holder = []

    def report(text: str) -> None:
        (holder[0].get_logger().error if holder else print)(text)   # holder: set once built

    node = LockstepControllerNode(
        node_name, schema=core_class.SCHEMA, channels=channels,
        make_core=lambda params: CheckedCore(core_class(params), report), **kwargs)
    holder.append(node)
    return node


def run_controller(core_class: type, node_name: str, args=None, *, status: bool = True) -> int:
    """``main`` of a drive controller node: core_class wrapped in the built-ins' node base.

    Subscribes ``drive/measurement``, publishes ``drive/gate_command`` (and
    ``dtc/status`` when status is True), parameters from ``core_class.SCHEMA``.
    Returns the exit code (0 on SIGINT/SIGTERM, 2 with a one-line error when
    the node cannot start, e.g. a rejected parameter).
    """
    from drive_common.node_main import run_node
    return run_node(lambda: controller_node(core_class, node_name, status=status), args,
                    about=core_class)
