"""What one lockstep message costs its taker and its publisher: typed messages vs serialized bytes.

In one process (Fast DDS delivers within the process), for DriveMeasurement
and GateCommand: the take as a Python message (rclpy's default) against the
raw take plus :class:`drive_common.lockstep_wire.LockstepWire` decoding into
the core sample (``from_message`` after a typed take, for the same
result), and the publish of a refilled message (``ReusedMessage.fill``)
against publishing ``LockstepWire.encode``'s bytes. Wall us per message,
best of --repeats batches (benchmarks/timing.py).

    source scripts/env.sh && python benchmarks/bench_lockstep_wire.py [--messages 2000]
"""
from __future__ import annotations

import argparse
import time

import rclpy

from drive_common.conversions import ReusedMessage, from_message
from drive_common.lockstep_wire import LockstepWire
from drive_common.samples import DriveSample, GateSample
from drive_common.topics import LOCKSTEP_QOS
from drive_common.waiting import wait_until

SAMPLES = {
    DriveSample: DriveSample(7, 0.25, (1.0, -2.0, float('nan')), 56.5, 28.25, 123, 1.5, 3, 30.0),
    GateSample: GateSample(7, 6, (True, False, False, True, False, True)),
}


def per_message_us(node, msg_type, sample, raw: bool, messages: int) -> tuple[float, float]:
    """(publish us, take-to-sample us) per message, typed or raw."""
    topic = f'/bench_wire/{msg_type.__name__}_{"raw" if raw else "typed"}'
    pub = node.create_publisher(msg_type, topic, LOCKSTEP_QOS)
    sub = node.create_subscription(msg_type, topic, lambda m: None, LOCKSTEP_QOS, raw=raw)
    wait_until(lambda: pub.get_subscription_count() >= 1, 10.0, 0.01)
    wire = LockstepWire(msg_type, type(sample))
    filled = ReusedMessage(msg_type)
    publish_s = take_s = 0.0
    for k in range(messages):
        start = time.perf_counter()
        pub.publish(wire.encode(sample, 0, k) if raw else filled.fill(sample, stamp=None))
        publish_s += time.perf_counter() - start
        taken = None
        while taken is None:
            start = time.perf_counter()
            with sub.handle:
                taken = sub.handle.take_message(msg_type, raw)
            if taken is not None:
                (wire.decode(taken[0]) if raw else from_message(taken[0], type(sample)))
            take_s += time.perf_counter() - start
    node.destroy_subscription(sub)
    node.destroy_publisher(pub)
    return 1e6 * publish_s / messages, 1e6 * take_s / messages


def main() -> int:
    from dtc_msgs.msg import DriveMeasurement, GateCommand
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--messages', type=int, default=2000)
    parser.add_argument('--repeats', type=int, default=3)
    args = parser.parse_args()
    rclpy.init()
    try:
        node = rclpy.create_node('bench_lockstep_wire')
        print(f'{"message":18s} {"way":6s} {"publish us":>11s} {"take->sample us":>16s}')
        for msg_type, sample in ((DriveMeasurement, SAMPLES[DriveSample]),
                                 (GateCommand, SAMPLES[GateSample])):
            for raw in (False, True):
                runs = [per_message_us(node, msg_type, sample, raw, args.messages)
                        for _ in range(args.repeats)]
                publish = min(r[0] for r in runs)
                take = min(r[1] for r in runs)
                print(f'{msg_type.__name__:18s} {"bytes" if raw else "typed":6s} '
                      f'{publish:11.1f} {take:16.1f}')
        node.destroy_node()
    finally:
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
