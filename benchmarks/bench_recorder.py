"""Recorder size, memory and completeness on the real graph (its speed and size goals).

Runs a T_s = 25 us scenario (six-switch two-phase DTC, 000 Figs. 2.9-2.11)
through the ROS graph with the recorder for 1 s of sim time (40 000
samples), then prints: the bag size on disk (goal < 100 MB with
compression), the recorder's peak resident memory (goal < 300 MB), and the
samples the bag's telemetry blocks hold against the samples the plant ran
(nothing lost, no step skipped or repeated), and how long the recorder takes to stop once the run
is over (drain, write what it held, finish the file). The wall-time overhead of recording is measured
by benchmarks/bench_scenario_ros.py (same graph with and without recorder).

    source scripts/env.sh && python benchmarks/bench_recorder.py [--duration 1.0] [--scenario NAME]
"""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from drive_bringup.runner import GraphRunner
from drive_bringup.scenario import find_scenario, load_scenario
from drive_testing.harness import reserve_domain
from drive_logger.bag_reader import BagReader

from bench_scenario_ros import bag_samples   # benchmarks/ is on sys.path when run as a script

SCENARIO = 'two_phase_six_switch_nonideal_torque'


def vm_hwm_mb(pid: int) -> float:
    for line in Path(f'/proc/{pid}/status').read_text().splitlines():
        if line.startswith('VmHWM:'):
            return int(line.split()[1]) / 1024
    return float('nan')


class MeasuredRunner(GraphRunner):
    """Reads the recorder's peak memory once the run is over, before it stops."""

    def _drive(self, node, executor, bag_dir):
        result = super()._drive(node, executor, bag_dir)
        self.recorder_hwm_mb = vm_hwm_mb(self.processes['recorder'].pid)
        return result

    def _stop_all(self):
        recorder, stop = self.processes.get('recorder'), None
        if recorder is not None:
            stop = recorder.stop

            def timed_stop(*args, **kwargs):
                start = time.monotonic()
                code = stop(*args, **kwargs)
                self.recorder_stop_s = time.monotonic() - start
                return code
            recorder.stop = timed_stop
        super()._stop_all()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--duration', type=float, default=None,
                        help='sim seconds, at most the scenario\'s (default: all of it)')
    parser.add_argument('--scenario', default=SCENARIO, help=f'a 25 us scenario (default {SCENARIO}, 0.12 s)')
    args = parser.parse_args()
    scenario = load_scenario(find_scenario(args.scenario))
    if args.duration is not None:
        scenario = scenario.shortened(args.duration)
    with reserve_domain() as domain, tempfile.TemporaryDirectory() as tmp:
        runner = MeasuredRunner(scenario, Path(tmp) / 'run', domain_id=domain,
                                progress=lambda m: None)
        result = runner.run()
        size = sum(f.stat().st_size for f in result.bag.iterdir())
        counts = {t: i.message_count for t, i in BagReader(result.bag).topics.items()}
        in_blocks = bag_samples(result.bag)
    steps = result.final_step
    print(f'{scenario.name}: {steps} samples ({result.final_time:.3f} s sim at 25 us) in '
          f'{result.wall_time:.1f} s wall')
    print(f'bag size on disk (lz4)           : {size / 1e6:.1f} MB for {result.final_time:.3f} s '
          f'-> {size / 1e6 / result.final_time:.1f} MB per sim second (goal < 100 MB)')
    print(f'recorder peak resident memory    : {runner.recorder_hwm_mb:.0f} MB (goal < 300 MB)')
    print(f'recorder stop (run over -> bag closed): {runner.recorder_stop_s:.2f} s')
    expected = {'/dtc/status_block': steps, '/plant/state_block': steps + 1}
    lost = {t: n - in_blocks.get(t, (0, []))[0] for t, n in expected.items()
            if in_blocks.get(t, (0, []))[0] != n or in_blocks[t][1]}
    print(f'messages in the bag              : {counts}')
    print('samples in the blocks            : '
          + ', '.join(f'{t} {n} (step gaps: {len(gaps)})' for t, (n, gaps) in in_blocks.items()))
    print('nothing lost' if not lost else f'LOST messages (expected - recorded): {lost}')
    return 0 if not lost else 1


if __name__ == '__main__':
    raise SystemExit(main())
