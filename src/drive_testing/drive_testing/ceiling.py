"""The raw rclpy publish -> reply ceiling of the lockstep protocol (docs/benchmarks.md).

``raw_responder`` answers each DriveMeasurement with a GateCommand of the same step, nothing
else; :func:`measure_round_trips` waits for each reply as the plant does (a wait set, bytes via
:mod:`drive_common.lockstep_wire`). The naive ceiling is plain rclpy: ``naive_responder`` and
:func:`measure_naive_round_trips` reply and wait through SingleThreadedExecutor callbacks.
"""
from __future__ import annotations

import threading
import time

import rclpy
from dtc_msgs.msg import DriveMeasurement, GateCommand
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from drive_common import topics
from drive_common.node_main import run_node
from drive_common.lockstep_io import DirectReceiver
from drive_common.lockstep_wire import LockstepWire
from drive_common.samples import ALL_OFF, DriveSample, GateSample
from drive_common.waiting import wait_until


class RawResponder(Node):
    """Answers each measurement with a fixed command: the lockstep nodes' publish/take, nothing else."""

    def __init__(self, **kwargs) -> None:
        super().__init__('raw_responder', **kwargs)
        measurement = LockstepWire(DriveMeasurement, DriveSample)
        command = LockstepWire(GateCommand, GateSample)
        pub = self.create_publisher(GateCommand, topics.GATE_COMMAND, topics.LOCKSTEP_QOS)

        def answer(data: bytes) -> None:
            sample, sec, nanosec = measurement.decode(data)
            pub.publish(command.encode(GateSample(sample.step, 6, ALL_OFF), sec, nanosec))

        # Same receive path as the lockstep nodes: a wait set, no executor per message.
        self._io = rclpy.create_node('raw_responder_io', context=self.context,
                                     start_parameter_services=False)
        receiver = DirectReceiver(self.context, [self._io.create_subscription(
            DriveMeasurement, topics.DRIVE_MEASUREMENT, answer, topics.LOCKSTEP_QOS, raw=True)])

        def loop() -> None:
            while rclpy.ok(context=self.context):
                try:
                    receiver.poll(0.1)
                except Exception:  # noqa: BLE001 - context shut down under the wait
                    return

        threading.Thread(target=loop, daemon=True).start()


def measure_round_trips(context, samples: int = 2000, timeout: float = 30.0) -> float:
    """Round trips per wall second against a running raw_responder."""
    node = rclpy.create_node('ceiling_probe', context=context)
    replies: dict[int, object] = {}
    measurement, command = LockstepWire(DriveMeasurement, DriveSample), LockstepWire(GateCommand, GateSample)
    pub = node.create_publisher(DriveMeasurement, topics.DRIVE_MEASUREMENT, topics.LOCKSTEP_QOS)

    def reply(data: bytes) -> None:
        sample = command.decode(data)[0]
        replies[sample.step] = sample

    receiver = DirectReceiver(context, [node.create_subscription(
        GateCommand, topics.GATE_COMMAND, reply, topics.LOCKSTEP_QOS, raw=True)])
    try:
        wait_until(lambda: pub.get_subscription_count() >= 1
                   and node.count_publishers(topics.GATE_COMMAND) >= 1,
                   timeout, 0.01, 'raw_responder matched', pause=receiver.poll)
        sample = DriveSample(0, 0.0, (1.0, -1.0, float('nan')), 0.0, 0.0, 0, 0.0, 0, 0.0)
        for warm in range(2):
            start = time.perf_counter()
            for k in range(samples):
                sample.step = k + warm * samples
                pub.publish(measurement.encode(sample, 0, k))
                while replies.pop(sample.step, None) is None:
                    receiver.poll(1.0)
            elapsed = time.perf_counter() - start
        return samples / elapsed
    finally:
        node.destroy_node()


class NaiveResponder(Node):
    """Answers each measurement from a subscription callback (the textbook rclpy ping-pong)."""

    def __init__(self, **kwargs) -> None:
        super().__init__('naive_responder', **kwargs)
        pub = self.create_publisher(GateCommand, topics.GATE_COMMAND, topics.LOCKSTEP_QOS)

        def answer(msg) -> None:
            pub.publish(GateCommand(topology=6, step=msg.step, header=msg.header))

        self.create_subscription(DriveMeasurement, topics.DRIVE_MEASUREMENT, answer,
                                 topics.LOCKSTEP_QOS)


def measure_naive_round_trips(context, samples: int = 2000, timeout: float = 30.0) -> float:
    """Round trips per wall second against a running naive_responder, probe spun by an executor."""
    node = rclpy.create_node('naive_probe', context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    replies: set[int] = set()
    pub = node.create_publisher(DriveMeasurement, topics.DRIVE_MEASUREMENT, topics.LOCKSTEP_QOS)
    node.create_subscription(GateCommand, topics.GATE_COMMAND, lambda m: replies.add(m.step),
                             topics.LOCKSTEP_QOS)
    try:
        wait_until(lambda: pub.get_subscription_count() >= 1
                   and node.count_publishers(topics.GATE_COMMAND) >= 1,
                   timeout, 0.01, 'naive_responder matched',
                   pause=lambda t: executor.spin_once(timeout_sec=t))
        for warm in range(2):
            start = time.perf_counter()
            for k in range(samples):
                step = k + warm * samples
                pub.publish(DriveMeasurement(step=step, phase_current=[1.0, -1.0, float('nan')]))
                deadline = time.monotonic() + timeout
                while step not in replies:
                    executor.spin_once(timeout_sec=0.1)
                    if step not in replies and time.monotonic() > deadline:
                        raise TimeoutError(f'naive_responder did not answer step {step} in {timeout} s')
                replies.discard(step)
            elapsed = time.perf_counter() - start
        return samples / elapsed
    finally:
        executor.shutdown()
        node.destroy_node()


def main(args=None) -> int:
    return run_node(RawResponder, args)


def naive_main(args=None) -> int:
    return run_node(NaiveResponder, args)
