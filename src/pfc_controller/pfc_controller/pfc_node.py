"""pfc_controller node: the lockstep ROS wrapper around :class:`~pfc_controller.core.PfcCore`.

Subscribes ``pfc/measurement`` (dtc_msgs/PfcMeasurement), answers every
sample with ``pfc/duty_command`` (dtc_msgs/DutyCommand, same step and stamp)
and publishes ``pfc/status`` (dtc_msgs/PfcStatus). Parameters: see
:data:`pfc_controller.parameters.PFC_SCHEMA`; a change is validated by
``PfcCore.check``; accepted changes act from the next sample, rejected ones
keep the old value and return the reason.
Run: ``ros2 run pfc_controller pfc_controller --ros-args -p voltage_reference:=90.0``.
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
