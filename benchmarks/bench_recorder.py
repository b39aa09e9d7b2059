#!/usr/bin/env python3
"""Recorder cost on a synthetic lockstep drive graph (a benchmark, not a test).

A stand-in plant (this process) publishes, per step, drive/measurement,
plant/state and /clock and waits for the gate command of a stand-in
controller process, which also publishes dtc/status; messages have the
graph's real types and sizes. The run is timed without and with the recorder
(all graph topics), and the script prints the wall-time overhead, the bag
size scaled to a 1 s run at T_s = 25 us (40 000 steps) and the recorder's
peak resident memory (VmHWM).

    source scripts/env.sh && python benchmarks/bench_recorder.py [--steps 20000]
"""
from __future__ import annotations

import argparse
import math
import os
import shutil
import sys
import tempfile
import threading
import time
from pathlib import Path

TS = 25e-6


def controller_main() -> None:
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from drive_common.topics import DRIVE_MEASUREMENT, DTC_STATUS, GATE_COMMAND, LOCKSTEP_QOS
    from dtc_msgs.msg import DriveMeasurement, DtcStatus, GateCommand
    rclpy.init()
    node = rclpy.create_node('bench_controller')
    gate_pub = node.create_publisher(GateCommand, GATE_COMMAND, LOCKSTEP_QOS)
    status_pub = node.create_publisher(DtcStatus, DTC_STATUS, LOCKSTEP_QOS)

    def on_meas(msg):
        gate = GateCommand(step=msg.step, topology=6, switch_on=[msg.step % 2 == 0] * 6)
        gate.header.stamp = msg.header.stamp
        status = DtcStatus(step=msg.step, mode='bench', torque_reference=0.3, torque_estimate=0.29,
                           flux_alpha=0.1, flux_beta=0.0, flux_magnitude=0.1, switch_on=gate.switch_on)
        status.header.stamp = msg.header.stamp
        gate_pub.publish(gate)
        status_pub.publish(status)

    node.create_subscription(DriveMeasurement, DRIVE_MEASUREMENT, on_meas, LOCKSTEP_QOS)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    rclpy.try_shutdown()


def run_plant(node, steps: int) -> float:
    """Lockstep loop: publish sample k, wait for gate k; return wall seconds."""
    from drive_common.conversions import time_msg
    from drive_common.harness import wait_until
    from drive_common.topics import CLOCK, DRIVE_MEASUREMENT, GATE_COMMAND, LOCKSTEP_QOS, PLANT_STATE
    from dtc_msgs.msg import DriveMeasurement, GateCommand, PlantState
    from rosgraph_msgs.msg import Clock
    got = threading.Condition()
    last = [-1]

    def on_gate(msg):
        with got:
            last[0] = msg.step
            got.notify_all()

    sub = node.create_subscription(GateCommand, GATE_COMMAND, on_gate, LOCKSTEP_QOS)
    pubs = (node.create_publisher(DriveMeasurement, DRIVE_MEASUREMENT, LOCKSTEP_QOS),
            node.create_publisher(PlantState, PLANT_STATE, LOCKSTEP_QOS),
            node.create_publisher(Clock, CLOCK, 10))
    wait_until(lambda: pubs[0].get_subscription_count() >= 1 and node.count_publishers(GATE_COMMAND) >= 1,
               20.0, what='controller')
    time.sleep(0.5)
    meas, state, clock = DriveMeasurement(), PlantState(), Clock()
    start = time.perf_counter()
    for k in range(steps):
        stamp = time_msg(k * TS)
        w = k * TS * 2 * math.pi * 100
        meas.step = state.step = k
        meas.header.stamp = state.header.stamp = clock.clock = stamp
        meas.phase_current = state.phase_current = [math.sin(w), math.sin(w - 2.094), math.sin(w + 2.094)]
        state.electromagnetic_torque = 0.3 + 0.01 * math.sin(40 * w)
        state.rotor_angle = w % (2 * math.pi)
        pubs[2].publish(clock)
        pubs[0].publish(meas)
        pubs[1].publish(state)
        with got:
            if not got.wait_for(lambda: last[0] >= k, timeout=5.0):
                raise RuntimeError(f'no gate command for step {k}')
    elapsed = time.perf_counter() - start
    for p in pubs:
        node.destroy_publisher(p)
    node.destroy_subscription(sub)
    return elapsed


def vm_hwm_mb(pid: int) -> float:
    for line in Path(f'/proc/{pid}/status').read_text().splitlines():
        if line.startswith('VmHWM:'):
            return int(line.split()[1]) / 1024
    return float('nan')


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--steps', type=int, default=20000)
    ap.add_argument('--compression', default='lz4')
    ap.add_argument('--controller', action='store_true', help=argparse.SUPPRESS)
    args, _ = ap.parse_known_args()  # the controller mode gets --ros-args too
    if args.controller:
        controller_main()
        return 0
    from drive_common.harness import NodeProcess, RosSession, isolated_env, reserve_domain
    from drive_logger.readiness import wait_for_recorder
    from drive_logger.compare_replay import CommandProcess
    work = Path(tempfile.mkdtemp(prefix='bench_recorder_'))
    with reserve_domain() as domain:
        env = isolated_env(domain)
        os.environ['ROS_DOMAIN_ID'] = str(domain)
        controller = CommandProcess([sys.executable, __file__, '--controller'], env=env, log_dir=work)
        session = RosSession(domain)
        try:
            plain = run_plant(session.node('bench_plant_a'), args.steps)
            recorder = NodeProcess('drive_logger', 'recorder', env=env, log_dir=work,
                                   parameters={'output': str(work / 'bag'), 'compression': args.compression})
            node = session.node('bench_plant_b')
            wait_for_recorder(node, timeout=30.0)
            time.sleep(1.0)  # the controller already runs: let its writers match the new recorder
            recorded = run_plant(node, args.steps)
            time.sleep(0.5)
            hwm = vm_hwm_mb(recorder.pid)
            recorder.stop(timeout=30)
            plain = (plain + run_plant(session.node('bench_plant_c'), args.steps)) / 2  # before and after
        finally:
            controller.stop()
            session.close()
    from drive_logger.bag_reader import BagReader
    reader = BagReader(work / 'bag')
    counts = {t: i.message_count for t, i in reader.topics.items() if i.message_count}
    size = sum(f.stat().st_size for f in (work / 'bag').iterdir())
    per_step = size / args.steps
    print(f'steps: {args.steps} (T_s = 25 us -> {args.steps * TS:.3f} s of sim time), compression {args.compression}')
    print(f'messages recorded: {counts}')
    print(f'wall time without recorder (mean of a run before and after): {plain:.2f} s, with recorder: {recorded:.2f} s, '
          f'overhead {100 * (recorded / plain - 1):+.1f} %')
    print(f'bag size: {size / 1e6:.2f} MB = {per_step:.0f} B/step -> 1 s at 25 us (40000 steps): '
          f'{per_step * 40000 / 1e6:.1f} MB')
    print(f'recorder peak resident memory (VmHWM): {hwm:.0f} MB')
    shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
