"""What one more subscriber costs the publishing process (the floor of recording overhead).

Publishes dtc_msgs/PlantState (STREAM_QOS, reliable) at a lockstep-like pace
(one message per 200 us) and measures the publisher process's CPU time per
message with 0, 1 and 2 subscribers, each a separate process that takes the
messages raw in its own wait loop (as the recorder does). rclpy holds the GIL
for the whole publish, so this CPU lands on the publishing node's lockstep
thread. In the default scenario the recorder is the first subscriber of
plant/state and dtc/status and the second of drive/measurement and
drive/gate_command: four such costs per sample.

    source scripts/env.sh && python benchmarks/bench_publish_cost.py [--messages 5000]
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import time

PACE_S = 200e-6

SUBSCRIBER = """
import sys, time, rclpy
from dtc_msgs.msg import PlantState
from drive_common.lockstep_io import DirectReceiver
from drive_common.topics import STREAM_QOS
rclpy.init()
node = rclpy.create_node('bench_subscriber')
sub = node.create_subscription(PlantState, '/bench/state', lambda data: None, STREAM_QOS, raw=True)
receiver = DirectReceiver(node.context, [sub])
while rclpy.ok():
    receiver.poll(0.1)
"""


def cpu_per_message_us(publisher, msg, count: int) -> float:
    time.sleep(0.5)   # let discovery traffic settle
    c0 = time.process_time()
    for _ in range(count):
        publisher.publish(msg)
        time.sleep(PACE_S)
    return (time.process_time() - c0) / count * 1e6


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--messages', type=int, default=5000, help='messages per measurement')
    args = parser.parse_args()

    import rclpy
    from dtc_msgs.msg import PlantState

    from drive_testing.harness import private_domain
    from drive_common.topics import STREAM_QOS
    from drive_common.waiting import wait_until

    with private_domain() as (_, context, env):
        subscribers: list[subprocess.Popen] = []
        try:
            node = rclpy.create_node('bench_publisher', context=context)
            publisher = node.create_publisher(PlantState, '/bench/state', STREAM_QOS)
            msg = PlantState()
            rows = []
            for wanted in range(3):
                while len(subscribers) < wanted:
                    subscribers.append(subprocess.Popen([sys.executable, '-c', SUBSCRIBER],
                                                        env=env))
                if not wait_until(lambda: publisher.get_subscription_count() >= wanted, 30.0, 0.05,
                                  raise_timeout=False):
                    print(f'no match with {wanted} subscriber(s) within 30 s', file=sys.stderr)
                    return 1
                rows.append(cpu_per_message_us(publisher, msg, args.messages))
            # The idle pace itself (sleep wake-ups) costs CPU too; subtract it.
            pace = cpu_per_message_us(type('Idle', (), {'publish': staticmethod(lambda m: None)}),
                                      msg, args.messages)
        finally:
            for process in subscribers:
                process.terminate()
                process.wait(timeout=10)
    print(f'PlantState publish, reliable, one per {PACE_S * 1e6:.0f} us; publisher CPU per message '
          f'(pacing sleep of {pace:.1f} us subtracted):')
    for n, cost in enumerate(rows):
        extra = '' if n == 0 else f'  (+{cost - rows[n - 1]:.1f} us for subscriber {n})'
        print(f'  {n} subscriber(s): {cost - pace:6.1f} us{extra}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
