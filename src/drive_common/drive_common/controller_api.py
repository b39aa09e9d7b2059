"""Write your own drive controller: the public contract and a one-call ``main``.

A ROS-free core (:class:`ControllerCore`) answers each ``drive/measurement`` of step k with
a command of step k; :func:`run_controller` wraps it in the built-ins' node base
(docs/write_your_own_controller.md). Imports no rclpy: a core module may import it.
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
    """What a drive controller core provides (no rclpy): ``SCHEMA``, ``__init__(params)``,
    ``update(sample)`` (:class:`DriveSample` of step k -> (:class:`GateSample` of step k, status
    or None)), ``reconfigure(params)``, optionally ``check(params)`` (docs/write_your_own_controller.md).
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
    """Why a core's answer to sample ``step`` is malformed (not a GateSample, switch_on not 6
    bools, another step: the plant cannot see a wrong length), or None."""
    if not isinstance(command, GateSample):
        return f'update returned {type(command).__name__}, not a GateSample'
    switches = command.switch_on
    if len(switches) != 6 or not all(isinstance(s, bool) or type(s).__name__ == 'bool_' for s in switches):
        return f'switch_on must be 6 bools (SW1..SW6), got {switches!r}'
    if command.step != step:
        return f'command for step {command.step} answers the sample of step {step}'
    return None


class CheckedCore:
    """A core whose commands are checked before they are sent (:func:`command_problem`); a
    malformed one is reported and raises :class:`MalformedCommand` (the node ends)."""

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
    from drive_common.lockstep_controller import LockstepControllerNode, gate_channels
    holder = []

    def report(text: str) -> None:
        (holder[0].get_logger().error if holder else print)(text)   # holder: set once built

    node = LockstepControllerNode(
        node_name, schema=core_class.SCHEMA, channels=gate_channels(status),
        make_core=lambda params: CheckedCore(core_class(params), report), **kwargs)
    holder.append(node)
    return node


def run_controller(core_class: type, node_name: str, args=None, *, status: bool = True) -> int:
    """``main`` of a drive controller node (``drive/measurement`` in, ``drive/gate_command`` and,
    with status, ``dtc/status`` out; parameters from ``core_class.SCHEMA``); the exit code."""
    from drive_common.node_main import run_node
    return run_node(lambda: controller_node(core_class, node_name, status=status), args,
                    about=core_class)
