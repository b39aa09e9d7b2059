"""Per-sample telemetry vs sample blocks: publisher CPU per sample and block size, to choose N.

(a) today's path: each sample fills (ReusedMessage) and publishes one
    dtc_msgs/PlantState and one DtcStatus (STREAM_QOS) to one subscriber;
(b) blocks: each sample goes into a BlockPacker for PlantStateBlock and one
    for DtcStatusBlock (status + measurement + command), and a block is
    published every N samples, N in --sizes.
Method of benchmarks/bench_publish_cost.py: samples paced one per 200 us,
publisher CPU time per sample above the same loop publishing nothing with
the subscriber matched (pacing sleeps, middleware threads); the one
subscriber is a separate process taking the messages raw in its own wait
loop (as the recorder does), and its CPU per sample is shown too
(/proc, 10 ms resolution, same baseline). Also prints the bare BlockPacker.append cost
(no ROS, per packer, best CPU time of 5) and the serialized block sizes.

    source scripts/env.sh && python benchmarks/bench_blocks.py [--samples 4000] [--sizes 10 20 40 80 160]
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

from bench_scenario_ros import cpu_seconds  # benchmarks/bench_scenario_ros.py
from timing import best_of  # benchmarks/timing.py
from drive_common.waiting import wait_until

PACE_S = 200e-6
SAMPLE_PERIOD_NS = 25_000          # 25 us samples, as the default scenario

SUBSCRIBER = """
import sys, rclpy, dtc_msgs.msg
from drive_common.lockstep_io import DirectReceiver
from drive_common.topics import STREAM_QOS
rclpy.init()
node = rclpy.create_node('bench_block_subscriber')
subs = [node.create_subscription(getattr(dtc_msgs.msg, name), '/bench/' + name, lambda data: None,
                                 STREAM_QOS, raw=True) for name in sys.argv[1:]]
receiver = DirectReceiver(node.context, subs)
while rclpy.ok():
    receiver.poll(0.1)
"""


def core_samples(count: int):
    """(PlantStateSample,), (DtcStatusSample, DriveSample, GateSample) per step, as the cores make them."""
    from bldc_plant_sim.core.plant import PlantStateSample
    from drive_common.samples import DriveSample, GateSample
    from dtc_controller.core.status import DtcStatusSample

    nan = float('nan')
    plant, dtc = [], []
    for k in range(count):
        x = 0.001 * k
        plant.append(PlantStateSample(
            k, (x, -x, 0.5), (1.0, 2.0, 3.0), (0.01, 0.02, 0.03), (1.0, 2.0, 3.0), 0.2, 0.3, 0.1,
            1.0 + x, 2.0 + x, 3.0, 300.0, 150.0, 150.0, nan, nan, nan, nan,
            (True, False, False, True, False, False), 0.0, False, 0, False,
            0.0, 1.0 + x, 0.1, 0.2, 0.0, 0.01, 0.3, 0.5))
        dtc.append((
            DtcStatusSample(k, 'two_phase_six_switch', 1, 100.0, 99.0 + x, 0.3, 0.29, nan, nan,
                            0.01, 0.02, 0.022, nan, nan, 0.1, 1.2, 1.0 + x, nan,
                            3, 1, 0, 0, 4, (True, False, False, True, False, False)),
            DriveSample(k, k * 25e-6, (x, -x, nan), 300.0, 150.0, k, 1.0 + x, 3, 99.0),
            GateSample(k, 6, (True, False, False, True, False, False))))
    return plant, dtc


def cpu_per_sample_us(step, count: int, subscriber: subprocess.Popen | None) -> tuple[float, float]:
    """(publisher CPU us, subscriber CPU us) per sample of step(k), paced like the lockstep."""
    time.sleep(0.5)   # let discovery traffic settle
    s0 = _process_cpu(subscriber)
    c0 = time.process_time()
    for k in range(count):
        step(k)
        time.sleep(PACE_S)
    cpu = (time.process_time() - c0) / count * 1e6
    time.sleep(0.3)   # let the subscriber take the last messages
    return cpu, (_process_cpu(subscriber) - s0) / count * 1e6


def _process_cpu(process: subprocess.Popen | None) -> float:
    """User + system CPU seconds of a child process (0 without one)."""
    return cpu_seconds(process.pid) if process is not None else 0.0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--samples', type=int, default=4000, help='samples per measurement')
    parser.add_argument('--sizes', type=int, nargs='+', default=[10, 20, 40, 80, 160],
                        help='block sizes N to measure')
    args = parser.parse_args()

    import rclpy
    from rclpy.serialization import serialize_message

    from drive_common.conversions import ReusedMessage
    from drive_testing.harness import private_domain
    from drive_common.telemetry_blocks import BlockPacker
    from drive_common.topics import STREAM_QOS
    from dtc_msgs.msg import DtcStatus, DtcStatusBlock, PlantState, PlantStateBlock

    plant, dtc = core_samples(args.samples)

    # Bare packing cost, no ROS: what the plant's and the controller's lockstep thread pay per sample.
    append_us = {}
    for size in args.sizes:
        costs = []
        for block_type, records in ((PlantStateBlock, [(p,) for p in plant]), (DtcStatusBlock, dtc)):
            def pack(packer, records=records):
                for k in range(args.samples):
                    packer.append(k * SAMPLE_PERIOD_NS, *records[k])
            _, cpu, _ = best_of(5, lambda: BlockPacker(block_type, size), pack)
            costs.append(cpu / args.samples * 1e6)
        append_us[size] = costs

    rows = []
    with private_domain() as (_, context, env):
        node = rclpy.create_node('bench_block_publisher', context=context)
        try:
            def measure(types, step):
                publishers = {t: node.create_publisher(t, '/bench/' + t.__name__, STREAM_QOS)
                              for t in types}
                subscriber = subprocess.Popen(
                    [sys.executable, '-c', SUBSCRIBER] + [t.__name__ for t in types],
                    env=env)
                try:
                    wait_until(lambda: all(p.get_subscription_count() >= 1 for p in publishers.values()),
                               30.0, 0.05, 'the subscriber to match')
                    # Idle baseline with the same matched graph: pacing sleeps and the
                    # middleware's own threads, which process_time counts too.
                    idle = cpu_per_sample_us(lambda k: None, args.samples, subscriber)
                    busy = cpu_per_sample_us(lambda k: step(publishers, k), args.samples, subscriber)
                    return busy[0] - idle[0], busy[1] - idle[1]
                finally:
                    subscriber.terminate()
                    subscriber.wait(timeout=10)
                    for publisher in publishers.values():
                        node.destroy_publisher(publisher)

            state_msg, status_msg = ReusedMessage(PlantState), ReusedMessage(DtcStatus)

            def per_sample(pubs, k):
                t = k * SAMPLE_PERIOD_NS * 1e-9
                pubs[PlantState].publish(state_msg.fill(plant[k], t))
                pubs[DtcStatus].publish(status_msg.fill(dtc[k][0], t))

            rows.append(('per-sample PlantState + DtcStatus', measure((PlantState, DtcStatus),
                                                                       per_sample), None))
            for size in args.sizes:
                packers = (BlockPacker(PlantStateBlock, size), BlockPacker(DtcStatusBlock, size))
                sizes: dict[str, int] = {}

                def blocks(pubs, k, packers=packers, sizes=sizes):
                    stamp = k * SAMPLE_PERIOD_NS
                    for packer, records in ((packers[0], (plant[k],)), (packers[1], dtc[k])):
                        block = packer.append(stamp, *records)
                        if block is not None:
                            pubs[type(block)].publish(block)
                            if type(block).__name__ not in sizes:   # measure once, off the loop's cost
                                sizes[type(block).__name__] = len(serialize_message(block))

                cost = measure((PlantStateBlock, DtcStatusBlock), blocks)
                rows.append((f'blocks N = {size}', cost, (size, sizes)))
        finally:
            node.destroy_node()

    print(f'{args.samples} samples paced one per {PACE_S * 1e6:.0f} us, one raw subscriber; '
          f'CPU per sample above the idle matched graph (pacing, middleware threads); '
          f'subscriber resolution {1e6 / (os.sysconf("SC_CLK_TCK") * args.samples):.1f} us')
    print(f'{"path":36s} {"publisher":>10s} {"subscriber":>11s} {"append state/status":>20s} '
          f'{"PlantStateBlock":>16s} {"DtcStatusBlock":>15s} {"bytes/sample":>13s}')
    for name, (publisher, subscriber), extra in rows:
        line = f'{name:36s} {publisher:8.1f}us {subscriber:9.1f}us'
        if extra is not None:
            size, sizes = extra
            plant_b, dtc_b = sizes.get('PlantStateBlock', 0), sizes.get('DtcStatusBlock', 0)
            line += (f' {append_us[size][0]:9.1f} /{append_us[size][1]:5.1f} us {plant_b:14d} B {dtc_b:13d} B '
                     f'{(plant_b + dtc_b) / size:11.0f} B')
        print(line)
    per_sample_bytes = len(serialize_message(ReusedMessage(PlantState).fill(plant[0], 0.0))) + \
        len(serialize_message(ReusedMessage(DtcStatus).fill(dtc[0][0], 0.0)))
    print(f'(per-sample PlantState + DtcStatus: {per_sample_bytes} B per sample serialized, '
          f'without the measurement and command the blocks also carry)')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
