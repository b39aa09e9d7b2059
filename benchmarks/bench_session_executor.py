"""Callback latency of a test session's executor: single- vs multi-threaded rclpy.

A test session (drive_testing.harness.RosSession) spins its executor in a
background thread while the test's thread publishes and waits on a condition
for the reply's callback. This measures that pattern against naive_responder
(drive_testing.ceiling), once per executor kind, and prints the median, 90th
percentile and worst round trip. The session uses the single-threaded executor
because rclpy's multi-threaded one was two orders of magnitude slower here.

    source scripts/env.sh && python benchmarks/bench_session_executor.py [--samples 300]
"""
from __future__ import annotations

import argparse
import statistics
import threading
import time

import rclpy
from rclpy.executors import MultiThreadedExecutor, SingleThreadedExecutor

from drive_common import topics
from drive_common.node_main import spin_in_background
from drive_common.waiting import wait_until
from drive_testing.harness import NodeProcess, private_domain
from dtc_msgs.msg import DriveMeasurement, GateCommand

EXECUTORS = {'single-threaded': lambda context: SingleThreadedExecutor(context=context),
             'multi-threaded (2)': lambda context: MultiThreadedExecutor(num_threads=2, context=context)}


def round_trips(context, make_executor, samples: int, timeout: float = 30.0) -> list[float]:
    """Wall seconds of each publish -> reply, the reply taken by a callback in the spinning thread."""
    executor = make_executor(context)
    node = rclpy.create_node('session_probe', context=context)
    executor.add_node(node)
    replies, arrived = set(), threading.Condition()

    def on_reply(msg) -> None:
        with arrived:
            replies.add(msg.step)
            arrived.notify_all()

    node.create_subscription(GateCommand, topics.GATE_COMMAND, on_reply, topics.LOCKSTEP_QOS)
    pub = node.create_publisher(DriveMeasurement, topics.DRIVE_MEASUREMENT, topics.LOCKSTEP_QOS)
    spinner = spin_in_background(executor, 'session_probe')
    try:
        wait_until(lambda: pub.get_subscription_count() >= 1
                   and node.count_publishers(topics.GATE_COMMAND) >= 1, timeout, what='naive_responder')
        step, seconds = 0, []
        while len(seconds) < samples:     # the first reply (matching) is not counted
            start = time.perf_counter()
            pub.publish(DriveMeasurement(step=step))
            with arrived:
                answered = arrived.wait_for(lambda: step in replies, timeout=1.0 if step == 0 else timeout)
            if step > 0 and not answered:
                raise TimeoutError(f'no reply to step {step} within {timeout} s')
            if answered and step > 0:
                seconds.append(time.perf_counter() - start)
            step += answered
        return seconds
    finally:
        executor.shutdown()
        spinner.join(timeout=5.0)
        node.destroy_node()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--samples', type=int, default=300)
    args = ap.parse_args()
    with private_domain() as (_, context, env):
        with NodeProcess('drive_testing', 'naive_responder', env=env):
            for name, make in EXECUTORS.items():
                s = sorted(round_trips(context, make, args.samples))
                print(f'{name:20s} median {statistics.median(s) * 1e3:8.2f} ms   '
                      f'p90 {s[int(0.9 * len(s))] * 1e3:8.2f} ms   max {s[-1] * 1e3:8.2f} ms')


if __name__ == '__main__':
    main()
