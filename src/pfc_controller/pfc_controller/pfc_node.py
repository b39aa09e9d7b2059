"""pfc_controller node: the lockstep ROS wrapper around :class:`~pfc_controller.core.PfcCore`.

Answers every ``pfc/measurement`` with a ``pfc/duty_command`` (same step and stamp) and publishes
``pfc/status``; parameter changes (:data:`pfc_controller.parameters.PFC_SCHEMA`) are validated by
``PfcCore.check`` and act from the next sample.
"""
from __future__ import annotations

from drive_common import topics
from drive_common.lockstep_controller import LockstepChannels, LockstepControllerNode
from drive_common.node_main import run_node
from drive_common.samples import PfcSample

from pfc_controller.core import PfcCore
from pfc_controller.parameters import PFC_SCHEMA


class PfcControllerNode(LockstepControllerNode):
    """Average current control boost PFC (000 ch. III) in the lockstep graph."""

    def __init__(self, **kwargs) -> None:
        from dtc_msgs.msg import DutyCommand, PfcMeasurement, PfcStatus, PfcStatusBlock
        super().__init__('pfc_controller', schema=PFC_SCHEMA, make_core=PfcCore,
                         channels=LockstepChannels(PfcMeasurement, topics.PFC_MEASUREMENT,
                                                   PfcSample, DutyCommand, topics.DUTY_COMMAND,
                                                   PfcStatus, topics.PFC_STATUS,
                                                   PfcStatusBlock, topics.PFC_STATUS_BLOCK), **kwargs)


def main(args=None) -> int:
    return run_node(PfcControllerNode, args)


if __name__ == '__main__':
    raise SystemExit(main())
