"""The raw rclpy publish -> reply ceiling of the lockstep protocol.

``raw_responder`` answers each DriveMeasurement with a GateCommand of the
same step and nothing else; :func:`measure_round_trips` publishes
measurements one at a time and waits for each reply the way the plant node
does (a private single-threaded executor spun by the stepping thread).
The plant's lockstep rate divided by this figure is the overhead ratio the
benchmarks report.
"""
from __future__ import annotations

import time

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from drive_common import topics
from drive_common.lockstep_controller import run_node


class RawResponder(Node):
    def __init__(self, **kwargs) -> None:
        from dtc_msgs.msg import DriveMeasurement, GateCommand
        super().__init__('raw_responder', **kwargs)
        self._reply = GateCommand(topology=6)
        pub = self.create_publisher(GateCommand, topics.GATE_COMMAND, topics.LOCKSTEP_QOS)

        def answer(msg) -> None:
            self._reply.step = msg.step
            self._reply.header.stamp = msg.header.stamp
            pub.publish(self._reply)

        self.create_subscription(DriveMeasurement, topics.DRIVE_MEASUREMENT, answer,
                                 topics.LOCKSTEP_QOS)


def measure_round_trips(context, samples: int = 2000, timeout: float = 30.0) -> float:
    """Round trips per wall second against a running raw_responder."""
    from dtc_msgs.msg import DriveMeasurement, GateCommand
    node = rclpy.create_node('ceiling_probe', context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    replies: dict[int, object] = {}
    pub = node.create_publisher(DriveMeasurement, topics.DRIVE_MEASUREMENT, topics.LOCKSTEP_QOS)
    node.create_subscription(GateCommand, topics.GATE_COMMAND,
                             lambda m: replies.__setitem__(m.step, m), topics.LOCKSTEP_QOS)
    try:
        deadline = time.monotonic() + timeout
        while (pub.get_subscription_count() < 1 or node.count_publishers(topics.GATE_COMMAND) < 1):
            if time.monotonic() > deadline:
                raise TimeoutError('raw_responder not matched')
            executor.spin_once(timeout_sec=0.01)
        msg = DriveMeasurement()
        msg.phase_current = [1.0, -1.0, float('nan')]
        for warm in range(2):
            start = time.perf_counter()
            for k in range(samples):
                msg.step = k + warm * samples
                pub.publish(msg)
                while replies.pop(msg.step, None) is None:
                    executor.spin_once(timeout_sec=1.0)
            elapsed = time.perf_counter() - start
        return samples / elapsed
    finally:
        executor.shutdown()
        node.destroy_node()


def main(args=None) -> int:
    return run_node(RawResponder, args)
