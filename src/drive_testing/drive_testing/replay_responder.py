"""replay_responder: deterministic stand-in controller for the replay regression tests.

Answers every drive/measurement with a GateCommand of the same step whose
switches depend on the measurement (hall code and current signs) and on an
internal counter (state), like a controller. ``corrupt_step`` (>= 0) flips SW1
at that step, to prove the comparison catches a difference.
"""
import sys

from rclpy.node import Node

from drive_common.node_main import run_node
from drive_common.topics import DRIVE_MEASUREMENT, GATE_COMMAND, LOCKSTEP_QOS
from dtc_msgs.msg import DriveMeasurement, GateCommand


class Responder(Node):
    def __init__(self, **kwargs):
        super().__init__('responder', **kwargs)
        self.corrupt_step = self.declare_parameter('corrupt_step', -1).value
        self.count = 0
        self.pub = self.create_publisher(GateCommand, GATE_COMMAND, LOCKSTEP_QOS)
        self.create_subscription(DriveMeasurement, DRIVE_MEASUREMENT, self.on_measurement, LOCKSTEP_QOS)

    def on_measurement(self, msg):
        self.count += 1
        bits = [bool(msg.hall_code & 1), bool(msg.hall_code & 2), bool(msg.hall_code & 4),
                bool(msg.phase_current[0] > 0), bool(msg.phase_current[1] > 0), self.count % 3 == 0]
        if msg.step == self.corrupt_step:
            bits[0] = not bits[0]
        out = GateCommand(step=msg.step, topology=GateCommand.TOPOLOGY_SIX_SWITCH, switch_on=bits)
        out.header.stamp = msg.header.stamp
        self.pub.publish(out)


def main(args=None) -> int:
    return run_node(Responder, args)


if __name__ == '__main__':
    sys.exit(main())
