"""The ``dtc_controller`` node: a thin lockstep wrapper over DtcCore (docs/architecture.md).

Answers each ``drive/measurement`` with a ``drive/gate_command`` for the same step and publishes
``dtc/status``; parameter changes are validated by ``DtcCore.check``. A bad back-EMF table stops
the node at start with a message naming the file (exit code 2).
"""
from __future__ import annotations

from dtc_controller.core.backemf_table import BackEmfTableError
from dtc_controller.core.controller import DtcCore
from dtc_controller.parameters import DTC_SCHEMA
from drive_common.lockstep_controller import LockstepControllerNode, gate_channels
from drive_common.node_main import run_node
from drive_common.parameters import ParameterError


def make_core(params: dict) -> DtcCore:
    try:
        return DtcCore(params)
    except BackEmfTableError as exc:
        raise ParameterError(str(exc)) from exc


class DtcControllerNode(LockstepControllerNode):
    def __init__(self, **kwargs) -> None:
        super().__init__('dtc_controller', schema=DTC_SCHEMA, make_core=make_core,
                         channels=gate_channels(), **kwargs)


def main(args=None) -> int:
    return run_node(DtcControllerNode, args)


if __name__ == '__main__':
    raise SystemExit(main())
