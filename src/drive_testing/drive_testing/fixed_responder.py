"""fixed_responder: a stand-in controller answering drive measurements with a fixed gate pattern.

It takes part in the lockstep protocol exactly as dtc_controller does, with
:class:`~drive_testing.fixed_commands.FixedGateCore`. Parameters: ``switch_on`` (6 values 0/1),
``topology`` (4 or 6).
"""
from __future__ import annotations

from drive_testing.fixed_commands import FixedGateCore
from drive_common.lockstep_controller import LockstepControllerNode, gate_channels
from drive_common.node_main import run_node
from drive_common.parameters import ParameterError, ParameterSpec, schema


def _check_pattern(values) -> None:
    if any(v not in (0.0, 1.0) for v in values['switch_on']):
        raise ParameterError('switch_on: each entry must be 0 or 1')


FIXED_RESPONDER_SCHEMA = schema([
    ParameterSpec('switch_on', [1.0, 0.0, 0.0, 1.0, 0.0, 0.0],
                  'gate states SW1..SW6 (1 = on) sent for every sample', length=6),
    ParameterSpec('topology', 6, 'inverter switches', choices=(4, 6)),
], _check_pattern)


class FixedResponderCore(FixedGateCore):
    """The fixed responder as a :class:`~drive_common.controller_api.ControllerCore`, so a
    scenario can name it as its ``controller`` (graph and headless)."""

    SCHEMA = FIXED_RESPONDER_SCHEMA

    def __init__(self, params: dict) -> None:
        super().__init__()
        self.reconfigure(params)


class FixedResponder(LockstepControllerNode):
    def __init__(self, **kwargs) -> None:
        super().__init__('fixed_responder', schema=FIXED_RESPONDER_SCHEMA, make_core=FixedResponderCore,
                         channels=gate_channels(status=False), **kwargs)


def main(args=None) -> int:
    return run_node(FixedResponder, args)


if __name__ == '__main__':
    raise SystemExit(main())
