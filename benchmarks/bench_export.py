"""Exporter and canonical-bag cost on a long bag: peak memory (RSS) and time.

Builds a synthetic block bag of --sim-seconds (default 60 s) at T_s = 25 us:
the blocks (80 samples) of a short headless run of the 25 us scenario
(benchmarks/bench_recorder.py's), repeated with their steps and stamps
advanced (as bench_telemetry.py's recorder memory run), zstd chunks like a
recorded bag. Then, each in its own process (peak RSS = the child's
ru_maxrss):

1. the recorder's writing: the bag's messages through
   drive_logger.sample_topics.CanonicalWriter (canonical order, 1 ms viewer
   topics derived), flushed now and then, as the recorder does while recording;
2. ``drive_logger export --to parquet`` (one row per sample);
3. ``drive_logger export --to mcap`` (one message per sample; the slowest).

Goal: every step's peak memory < 300 MB (streaming, bounded memory).

    source scripts/env.sh && python benchmarks/bench_export.py [--sim-seconds 60] [--skip-mcap]
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SCENARIO = 'two_phase_six_switch_nonideal_torque'
SOURCE_SECONDS = 0.02      # s of sim time actually simulated; the rest repeats it
GOAL_MB = 300.0

RECORD = '''
import sys
from drive_logger.bag_writer import BagWriter
from drive_logger.bag_reader import BagReader
from drive_logger.graph_topics import is_paced
from drive_logger.message_definitions import TypeDefinition
from drive_logger.sample_topics import CanonicalWriter, SampleTopics
source = BagReader(sys.argv[1])
paced = [t for t, info in source.topics.items() if is_paced(info.type)]
bag = CanonicalWriter(BagWriter(sys.argv[2], compression='zstd'), SampleTopics(1e-3), reserved=source.topics)
streams = {}
for n, m in enumerate(source.messages(), 1):      # as the recorder takes them, flushing now and then
    if m.topic not in streams:
        info = source.topics[m.topic]
        definition = TypeDefinition(info.type, source._schema_for(info.type).data.decode(), info.type_hash)
        streams[m.topic] = bag.add_topic(m.topic, definition, info.qos_profiles, paced=m.topic in paced)
    bag.write(streams[m.topic], m.data, m.log_time, m.publish_time)
    if n % 2000 == 0:
        bag.flush(bag.watermark(paced))
bag.close()
print(bag.writer.message_count)
'''


def synthetic_bag(path: Path, sim_seconds: float) -> int:
    """Write the long block bag; return its number of plant samples."""
    from rclpy.serialization import serialize_message
    from drive_bringup.scenario import find_scenario, load_scenario
    from drive_logger.bag_writer import BagWriter
    from drive_logger.message_definitions import type_definition
    from drive_logger import qos_yaml
    from drive_testing.block_bags import headless_samples, write_block_bag
    from drive_logger.block_topics import BLOCK_TOPICS, read_blocks
    from drive_logger.bag_reader import BagReader

    scenario = load_scenario(find_scenario(SCENARIO)).shortened(SOURCE_SECONDS)
    with tempfile.TemporaryDirectory() as tmp:
        source = write_block_bag(headless_samples(scenario), Path(tmp) / 'source', live_period=None)
        reader = BagReader(source)
        blocks = read_blocks(reader, [t for t in reader.topics if t in BLOCK_TOPICS])
    per_cycle = {t: sum(b.count for b in bs) for t, bs in blocks.items()}
    cycle_steps = min(per_cycle.values())             # dtc: steps, plant: steps + 1 (step 0)
    ts = scenario.overrides['plant'].get('base_tick', 25e-6)
    cycles = int(round(sim_seconds / (cycle_steps * ts)))
    writer = BagWriter(path, compression='zstd', log_time='sim')
    records = {t: writer.add_topic(t, type_definition(BLOCK_TOPICS[t][0]), [qos_yaml.profile()]) for t in blocks}
    order = sorted((b.first_step, t, b) for t, bs in blocks.items() for b in bs)
    for c in range(cycles):
        shift_steps = c * cycle_steps
        shift_ns = int(round(shift_steps * ts * 1e9))
        for first_step, topic, block in order:
            original = (block.first_step, block.header.stamp.sec, block.header.stamp.nanosec)
            ns = original[1] * 1_000_000_000 + original[2] + shift_ns
            block.first_step = first_step + shift_steps
            block.header.stamp.sec, block.header.stamp.nanosec = divmod(ns, 1_000_000_000)
            writer.write(records[topic], bytes(serialize_message(block)), ns, ns)
            block.first_step, block.header.stamp.sec, block.header.stamp.nanosec = original
    writer.close()
    return cycles * cycle_steps


WRAPPER = ('import resource, subprocess, sys; rc = subprocess.run(sys.argv[1:]).returncode; '
           'print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, file=sys.stderr); sys.exit(rc)')


def measured(command: list[str]) -> tuple[float, float]:
    """(wall s, peak RSS MB) of a child process (measured by a wrapper that runs only it)."""
    start = time.perf_counter()
    result = subprocess.run([sys.executable, '-c', WRAPPER, *command], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - start
    if result.returncode != 0:
        raise SystemExit(f'{command[:4]} failed: {result.stderr}')
    return wall, int(result.stderr.strip().splitlines()[-1]) / 1024


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--sim-seconds', type=float, default=60.0)
    parser.add_argument('--skip-mcap', action='store_true', help='leave out the full-rate viewer export')
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        bag = Path(tmp) / 'long'
        start = time.perf_counter()
        samples = synthetic_bag(bag, args.sim_seconds)
        size = sum(f.stat().st_size for f in bag.iterdir()) / 1e6
        print(f'synthetic bag: {args.sim_seconds:g} s sim at 25 us, {samples} samples, {size:.0f} MB zstd '
              f'({time.perf_counter() - start:.0f} s to write)')
        steps = [('recorder writing: canonical order + 1 ms viewer topics',
                  [sys.executable, '-c', RECORD, str(bag), str(Path(tmp) / 'canonical')]),
                 ('export --to parquet', [sys.executable, '-m', 'drive_logger.export', str(bag), '--to', 'parquet',
                                          str(Path(tmp) / 'tables'), '--quiet'])]
        if not args.skip_mcap:
            steps.append(('export --to mcap (every sample)', [sys.executable, '-m', 'drive_logger.export', str(bag),
                                                              '--to', 'mcap', str(Path(tmp) / 'viewer'), '--quiet']))
        print(f'{"step":55s} {"wall s":>8s} {"samples/s":>10s} {"peak RSS MB":>12s}  goal < {GOAL_MB:.0f} MB')
        for label, command in steps:
            wall, peak = measured(command)
            print(f'{label:55s} {wall:8.1f} {samples / wall:10.0f} {peak:12.0f}  '
                  f'{"met" if peak < GOAL_MB else "MISSED"}', flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
