"""replay_responder: deterministic stand-in controller for the replay regression tests.

Answers every drive/measurement with a GateCommand of the same step whose switches depend on
the measurement and an internal counter. ``corrupt_step`` (>= 0) flips SW1 at that step;
``drop_first`` ignores the first measurement. It logs ``gate_command matched N
subscription(s)`` on a change of its match count and ``gate_command acknowledged through step
K``, so tests wait on those instead of sleeping.
"""
import sys

from rclpy.duration import Duration
from rclpy.node import Node

from drive_common.node_main import run_node
from drive_common.topics import DRIVE_MEASUREMENT, GATE_COMMAND, LOCKSTEP_QOS
from dtc_msgs.msg import DriveMeasurement, GateCommand

REPORT_PERIOD = 0.02   # s wall: how often the match count and acknowledgements are checked


class Responder(Node):
    def __init__(self, **kwargs):
        super().__init__('responder', **kwargs)
        self.corrupt_step = self.declare_parameter('corrupt_step', -1).value
        self.dropping = self.declare_parameter('drop_first', False).value
        self.count = 0
        self.pub = self.create_publisher(GateCommand, GATE_COMMAND, LOCKSTEP_QOS)
        self.create_subscription(DriveMeasurement, DRIVE_MEASUREMENT, self.on_measurement, LOCKSTEP_QOS)
        self.matched = 0
        self.last_step = self.acked_step = -1
        self.last_reply = None
        self.create_timer(REPORT_PERIOD, self.report)

    def report(self) -> None:
        """Log a change of the publisher's match count, and the last step every reader acknowledged."""
        matched = self.pub.get_subscription_count()
        if matched != self.matched:
            self.matched = matched
            self.get_logger().info(f'gate_command matched {matched} subscription(s)')
        last = self.last_step
        if last > self.acked_step and self.pub.wait_for_all_acked(Duration(seconds=0)):
            self.acked_step = last
            self.get_logger().info(f'gate_command acknowledged through step {last}')

    def on_measurement(self, msg):
        if self.dropping:
            self.dropping = False
            return
        if msg.step == self.last_step:          # a repeated measurement: the same answer, as the
            self.pub.publish(self.last_reply)   # lockstep contract asks of every controller
            return
        self.count += 1
        bits = [bool(msg.hall_code & 1), bool(msg.hall_code & 2), bool(msg.hall_code & 4),
                bool(msg.phase_current[0] > 0), bool(msg.phase_current[1] > 0), self.count % 3 == 0]
        if msg.step == self.corrupt_step:
            bits[0] = not bits[0]
        out = GateCommand(step=msg.step, topology=GateCommand.TOPOLOGY_SIX_SWITCH, switch_on=bits)
        out.header.stamp = msg.header.stamp
        self.pub.publish(out)
        self.last_step, self.last_reply = msg.step, out


def main(args=None) -> int:
    return run_node(Responder, args)


if __name__ == '__main__':
    sys.exit(main())
