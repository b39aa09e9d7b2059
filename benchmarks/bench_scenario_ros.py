"""The default scenario through the ROS graph, recorded, vs the raw rclpy ceiling.

Measured in the same run and the same private DDS domain:
1. ceiling: raw_responder / measure_round_trips (publish -> reply, one at a time);
2. the default scenario (plant + dtc_controller + recorder as separate
   processes, driven by the scenario runner), samples per wall second of
   the Run goals (start-up and analysis excluded), median of --repeats runs.
Prints both and their ratio (goal >= 0.6), and the same run without the
recorder, so the recording overhead on the wall time shows (goal:
< 5 %; the default recording takes the telemetry blocks, not the per-sample
lockstep topics); the samples the bag holds (every plant and controller
sample, from the blocks); then each process's CPU time per sample during
the Run goals (from /proc/<pid>/stat), which bounds the rate: the graph
cannot run faster than its total CPU per sample divided by the machine's
cores.

    source scripts/env.sh && python benchmarks/bench_scenario_ros.py [--scenario NAME] [--duration 0.02]
"""
from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path

from drive_bringup.runner import GraphRunner
from drive_bringup.scenario import find_scenario, load_scenario
from drive_common.starter import proc_stat
from drive_testing.ceiling import measure_round_trips
from drive_testing.harness import NodeProcess, domain_context, isolated_env, reserve_domain

DEFAULT = 'two_phase_six_switch_torque_step'


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process (all its threads), s."""
    fields = proc_stat(pid)
    if fields is None:
        raise ProcessLookupError(f'no process {pid}')
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


class CpuMeasuringRunner(GraphRunner):
    """Notes each node process's CPU time between graph-up and the end of the Run goals."""

    def _wait_ready(self, *args):
        super()._wait_ready(*args)
        self.cpu_start = {k: cpu_seconds(p.pid) for k, p in self.processes.items()}

    def _drive(self, node, executor, bag_dir):
        result = super()._drive(node, executor, bag_dir)
        self.cpu_used = {k: cpu_seconds(p.pid) - self.cpu_start[k] for k, p in self.processes.items()}
        return result


def bag_samples(bag_dir: Path) -> dict[str, tuple[int, list[str]]]:
    """Block topic -> (samples in the bag, step gaps found)."""
    from drive_logger.bag_reader import BagReader
    from drive_logger.block_topics import block_summaries
    return block_summaries(BagReader(bag_dir))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--scenario', default=DEFAULT)
    parser.add_argument('--duration', type=float, default=None,
                        help='sim seconds, at most the scenario\'s (default: the whole scenario)')
    parser.add_argument('--repeats', type=int, default=3, help='runs of each variant (median)')
    args = parser.parse_args()
    scenario = load_scenario(find_scenario(args.scenario))
    if args.duration is not None:
        scenario = scenario.shortened(args.duration)
    with reserve_domain() as domain, tempfile.TemporaryDirectory() as tmp:
        with domain_context(domain) as context, \
                NodeProcess('drive_testing', 'raw_responder', env=isolated_env(domain)):
            ceiling = measure_round_trips(context, 4000)
        def one_run(record: bool, i: int):
            runner = CpuMeasuringRunner(scenario, Path(tmp) / f'run{record}{i}', domain_id=domain,
                                        record=record, progress=lambda m: None)
            result = runner.run()
            result.cpu_used = runner.cpu_used
            return result

        # Interleaved, so a change in the machine's load hits both variants alike.
        runs = {False: [], True: []}
        for i in range(args.repeats):
            for record in (False, True):
                runs[record].append(one_run(record, i))
        bare, result = (sorted(runs[r], key=lambda r: r.wall_time)[args.repeats // 2]
                        for r in (False, True))
        bag_dir = result.bag
        bag_mb = sum(f.stat().st_size for f in bag_dir.glob('*')) / 1e6
        in_bag = bag_samples(bag_dir)
    rate = result.samples_per_second
    print(f'raw rclpy publish->reply ceiling : {ceiling:8.0f} round trips/s')
    print(f'{scenario.name}: {result.final_step} samples, {result.final_time:.4f} s sim')
    print(f'recorded graph                   : {rate:8.0f} samples/s = {rate / ceiling:.2f} of the '
          f'ceiling (goal >= 0.60), {result.wall_time:.2f} s wall')
    overhead = 100 * (result.wall_time / bare.wall_time - 1)
    print(f'same graph, no recorder          : {bare.samples_per_second:8.0f} samples/s, '
          f'{bare.wall_time:.2f} s wall; recording adds {overhead:+.1f} % '
          f'(goal < 5 %: {"met" if overhead < 5 else "missed"})')
    for topic, (count, gaps) in in_bag.items():
        print(f'in the bag, {topic:21s}: {count} samples'
              + (f'; step gaps: {gaps[:3]}' if gaps else '; no step skipped or repeated'))
    print(f'bag size                         : {bag_mb:.1f} MB '
          f'({bag_mb / max(result.final_time, 1e-9):.0f} MB per sim second)')
    cores = os.cpu_count() or 1
    for label, run in (('recorded', result), ('no recorder', bare)):
        per_sample = {k: 1e6 * v / run.final_step for k, v in run.cpu_used.items()}
        total = sum(per_sample.values())
        print(f'CPU per sample, {label:11s}     : ' + ', '.join(f'{k} {v:.0f} us' for k, v in per_sample.items())
              + f'; total {total:.0f} us -> at most {cores / total * 1e6:.0f} samples/s on {cores} cores')


if __name__ == '__main__':
    main()
