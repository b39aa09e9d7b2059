"""The telemetry goals, all figures from one run of this one command, printed side by side.

Runs, in one private DDS domain, the pieces of the other benchmark scripts
(their functions, imported) and prints one table, each figure with its goal
and met/missed:

1. ceilings: the project's publish -> reply ceiling (drive_testing raw_responder,
   wait-set receive on both sides) and the naive rclpy ping-pong ceiling
   (naive_responder: reply from a subscription callback, SingleThreadedExecutor;
   the probe spins its own SingleThreadedExecutor);
2. the default scenario (plant + dtc_controller [+ recorder]) recorded and
   unrecorded, interleaved, median of --repeats each, run for --graph-duration s
   of sim time (default 0.3 s, 9000 samples: its own 0.04 s is 1200 samples, too
   few to see the steady rate past start-up); CPU per sample per process from
   /proc (benchmarks/bench_scenario_ros.py);
3. the plant against fixed_responder with computation_delay on, sequential
   and pipelined, alternated, best of --repeats (benchmarks/bench_plant_ros.py);
4. bag size per simulated second at T_s = 25 us (benchmarks/bench_recorder.py's
   scenario, recorded through the graph) with lz4 and with zstd chunks, each with
   the recorder's CPU per sample and a loss check, and the lossless floor of the
   same block columns (lossless_floor_mb);
5. the four-process PFC scenario pfc_no_load_fig_3_5, recorded, shortened to
   --pfc-duration s of sim time (default 0.2 s, 16 000 plant samples; samples/s
   are plant samples per wall second of the Run goals, as the 1,175 samples/s
   the issue measured);
6. recorder peak memory (VmHWM) for 10 s of sim time at 25 us (400 000 samples):
   the recorder alone, fed by a synthetic block publisher in this process that
   re-publishes the blocks of run 4's bag with their steps and stamps advanced,
   paced at --feed-rate samples per wall second (faster than the graph runs, so
   the recorder's backlog is at least the real one); the bag is then checked
   for every sample.

    source scripts/env.sh && python benchmarks/bench_telemetry.py [--quick]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import rclpy

from drive_bringup.runner import record_topics
from drive_bringup.scenario import find_scenario, load_scenario
from drive_common import topics
from drive_common.waiting import wait_until
from drive_testing.ceiling import measure_naive_round_trips, measure_round_trips
from drive_testing.harness import NodeProcess, domain_context, isolated_env, reserve_domain
from drive_logger.bag_reader import BagReader

from bench_plant_ros import TS, plant_rate            # benchmarks/ is on sys.path when run as a script
from bench_recorder import SCENARIO as BAG_SCENARIO, vm_hwm_mb
from bench_scenario_ros import DEFAULT, CpuMeasuringRunner, bag_samples
from timing import best_of

PFC_SCENARIO = 'pfc_no_load_fig_3_5'
PFC_TODAY = 1175.0        # samples/s, pfc_no_load_fig_3_5 recorded
MEMORY_SIM_S = 10.0


def progress(text: str) -> None:
    print(f'[{time.strftime("%H:%M:%S")}] {text}', file=sys.stderr, flush=True)


class BenchRunner(CpuMeasuringRunner):
    """A GraphRunner noting CPU per process and the recorder's peak memory; recorder compression set."""

    compression = None

    def _start(self, key, package, executable, parameters, node_name=None):
        if key == 'recorder' and self.compression:
            parameters = {**parameters, 'compression': self.compression}
        return super()._start(key, package, executable, parameters, node_name)

    def _drive(self, node, executor, bag_dir):
        result = super()._drive(node, executor, bag_dir)
        if 'recorder' in self.processes:
            self.recorder_hwm_mb = vm_hwm_mb(self.processes['recorder'].pid)
        return result


def run_graph(scenario, out: Path, domain: int, record: bool, compression: str | None = None):
    runner = BenchRunner(scenario, out, domain_id=domain, record=record, progress=lambda m: None)
    runner.compression = compression
    result = runner.run()
    result.cpu_us = {k: 1e6 * v / result.final_step for k, v in runner.cpu_used.items()}
    result.recorder_hwm_mb = getattr(runner, 'recorder_hwm_mb', float('nan'))
    if record:
        result.bag_mb = sum(f.stat().st_size for f in result.bag.iterdir()) / 1e6
    return result


def lost_samples(bag: Path, steps: int, pfc: bool = False) -> dict[str, int]:
    """Block topic -> samples missing (or step gaps) against a run of `steps` controller samples."""
    in_blocks = bag_samples(bag)
    expected = {'/dtc/status_block': steps, '/plant/state_block': steps + 1}
    return {t: n - in_blocks.get(t, (0, []))[0] for t, n in expected.items()
            if in_blocks.get(t, (0, []))[0] != n or in_blocks[t][1]}


def recorder_memory(source_bag: Path, out: Path, domain: int, sim_seconds: float,
                    feed_rate: float, scenario) -> tuple[float, float, dict]:
    """(recorder VmHWM MB, wall s, samples per block topic in its bag) for sim_seconds of blocks."""
    from drive_logger.block_topics import block_class, read_blocks
    from drive_logger.readiness import wait_for_recorder

    reader = BagReader(source_bag)
    streams = {topic: (block_class(topic), blocks) for topic, blocks in
               read_blocks(reader, [t for t in reader.topics if t.endswith('_block')]).items()}
    per_cycle = {t: sum(b.count for b in blocks) for t, (_, blocks) in streams.items()}
    cycle_steps = min(per_cycle.values())            # dtc: steps, plant: steps + 1 (step 0)
    cycles = int(round(sim_seconds / (cycle_steps * TS)))
    names = record_topics(scenario)
    env = isolated_env(domain)
    with domain_context(domain) as context:
        with NodeProcess('drive_logger', 'recorder', env=env,
                         parameters={'output': str(out), 'topics': names}) as recorder:
            node = rclpy.create_node('synthetic_blocks', context=context)
            pubs = {t: node.create_publisher(msg_type, t, topics.BLOCK_QOS)
                    for t, (msg_type, _) in streams.items()}
            wait_for_recorder(node, list(pubs), timeout=60.0)
            wait_until(lambda: all(p.get_subscription_count() >= 1 for p in pubs.values()), 30.0)
            # Interleave the topics' blocks in step order, as the graph publishes them.
            order = sorted((b.first_step, t, b) for t, (_, blocks) in streams.items() for b in blocks)
            start = time.perf_counter()
            sent = 0
            for c in range(cycles):
                shift_steps = c * cycle_steps
                shift_ns = int(round(shift_steps * TS * 1e9))
                for first_step, topic, block in order:
                    msg = block
                    original = (msg.first_step, msg.header.stamp.sec, msg.header.stamp.nanosec)
                    ns = original[1] * 1_000_000_000 + original[2] + shift_ns
                    msg.first_step = first_step + shift_steps
                    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(ns, 1_000_000_000)
                    pubs[topic].publish(msg)
                    msg.first_step, msg.header.stamp.sec, msg.header.stamp.nanosec = original
                    if topic == '/dtc/status_block':
                        sent += msg.count
                        lag = sent / feed_rate - (time.perf_counter() - start)
                        if lag > 0:
                            time.sleep(lag)
            wall = time.perf_counter() - start
            time.sleep(2.0)        # let the recorder take what is still in flight before we read its peak
            hwm = vm_hwm_mb(recorder.pid)
            node.destroy_node()
            recorder.stop(timeout=120.0)
    counts = {t: n for t, (n, _) in bag_samples(out).items()}
    return hwm, wall, {t: (counts.get(t, 0), cycles * per_cycle[t]) for t in streams}


def chunk_compression_us(bag: Path, samples: int, chunk_size: int = 1 << 20) -> dict[str, float]:
    """Uncompressed MB of the bag's messages and CPU us per sample of compressing them in chunks.

    The calls mcap's writer makes per chunk (lz4.frame.compress, zstandard.compress, default
    levels), on the recorder's default chunk size, best of 5 (benchmarks/timing.py).
    """
    import lz4.frame
    import zstandard

    from drive_logger.bag_reader import BagReader
    data = b''.join(m.data for m in BagReader(bag).messages())
    chunks = [data[i:i + chunk_size] for i in range(0, len(data), chunk_size)]
    out = {'raw MB': len(data) / 1e6}
    for name, compress in (('lz4', lz4.frame.compress), ('zstd', zstandard.compress)):
        _, cpu, _ = best_of(5, lambda: None, lambda _: [compress(c) for c in chunks])
        out[name] = 1e6 * cpu / samples
    return out


def lossless_floor_mb(bag: Path, chunk_size: int = 1 << 20) -> float:
    """MB of the bag's block columns under the strongest lossless float coding tried here.

    Each block column, as one stream per topic: 8-byte values XOR-ed with the
    previous sample's (Gorilla-style delta of the bits), byte planes split
    (the shuffle of Blosc/HDF5), then zstd at level 19 in chunk_size pieces.
    Not a format the bag can use (the messages must stay CDR of their .msg
    for ROS readers): a bound on what any lossless re-coding of the same
    fields could reach.
    """
    import numpy as np
    import zstandard

    from drive_common.telemetry_blocks import block_columns
    from drive_logger.block_topics import read_blocks
    reader = BagReader(bag)
    streams = []
    for blocks in read_blocks(reader, [t for t in reader.topics if t.endswith('_block')]).values():
        columns: dict[str, list] = {}
        for block in blocks:
            for name, values in block_columns(block).items():
                columns.setdefault(name, []).append(values)
        for name, parts in columns.items():
            values = np.concatenate(parts)
            if values.dtype.kind not in 'fiub':
                continue                       # per-block strings: a few bytes per block
            data = np.ascontiguousarray(values)
            if data.dtype.itemsize == 8:
                bits = data.view(np.uint64).reshape(len(data), -1).copy()
                bits[1:] ^= bits[:-1]
                data = bits.view(np.uint8).reshape(len(data), -1, 8).transpose(2, 1, 0)
            streams.append(np.ascontiguousarray(data).tobytes())
    raw = b''.join(streams)
    compressor = zstandard.ZstdCompressor(level=19)
    return sum(len(compressor.compress(raw[i:i + chunk_size]))
               for i in range(0, len(raw), chunk_size)) / 1e6


def goal(ok: bool) -> str:
    return 'met' if ok else 'MISSED'


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--quick', action='store_true', help='fewer samples and repeats (a smoke run)')
    parser.add_argument('--repeats', type=int, default=None, help='default 5, --quick 1')
    parser.add_argument('--pfc-duration', type=float, default=None,
                        help='sim s of pfc_no_load_fig_3_5 (default 0.2, --quick 0.02)')
    parser.add_argument('--graph-duration', type=float, default=None,
                        help='sim s of the default scenario runs (default 0.3, --quick 0.04)')
    parser.add_argument('--feed-rate', type=float, default=20000.0,
                        help='synthetic blocks, samples per wall second (default 20000)')
    args = parser.parse_args()
    repeats = args.repeats or (1 if args.quick else 5)
    samples = 2000 if args.quick else 8000
    pfc_s = args.pfc_duration or (0.02 if args.quick else 0.2)
    memory_s = 1.0 if args.quick else MEMORY_SIM_S
    began = time.perf_counter()
    default = load_scenario(find_scenario(DEFAULT)).with_duration(
        args.graph_duration or (0.04 if args.quick else 0.3))
    bag_scenario = load_scenario(find_scenario(BAG_SCENARIO))
    pfc = load_scenario(find_scenario(PFC_SCENARIO)).shortened(pfc_s)
    with reserve_domain() as domain, tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        env = isolated_env(domain)
        with domain_context(domain) as context:
            progress('ceilings')
            with NodeProcess('drive_testing', 'raw_responder', env=env):
                ceiling = measure_round_trips(context, samples)
            with NodeProcess('drive_testing', 'naive_responder', env=env):
                naive = measure_naive_round_trips(context, samples)
            progress('computation_delay on: sequential vs pipelined')
            delayed = {'sequential': 0.0, 'pipelined': 0.0}
            hung = {'sequential': 0, 'pipelined': 0}
            for _ in range(repeats):
                for mode in delayed:
                    try:
                        rate = plant_rate(context, env, samples, TS, computation_delay=True,
                                          pipelined=mode == 'pipelined', timeout=60.0)
                    except TimeoutError as exc:
                        progress(f'hung: {exc}')
                        hung[mode] += 1
                        continue
                    delayed[mode] = max(delayed[mode], rate)
            delayed = {m: r or float('nan') for m, r in delayed.items()}   # nan: every run hung

        progress(f'{DEFAULT}: recorded vs unrecorded, {repeats} each, interleaved')
        runs = {False: [], True: []}
        for i in range(repeats):
            for record in (False, True):
                runs[record].append(run_graph(default, tmp / f'default_{record}_{i}', domain, record))
        bare, recorded = (sorted(runs[r], key=lambda r: r.wall_time)[repeats // 2] for r in (False, True))
        default_lost = lost_samples(recorded.bag, recorded.final_step)

        default_blocks = {t: (n, BagReader(recorded.bag).topics[t].message_count)
                          for t, (n, _) in bag_samples(recorded.bag).items()}
        bags = {}
        for compression in ('lz4', 'zstd'):
            progress(f'{BAG_SCENARIO} recorded, {compression}')
            run = run_graph(bag_scenario, tmp / f'bag_{compression}', domain, True, compression)
            run.lost = lost_samples(run.bag, run.final_step)
            bags[compression] = run

        compression_cost = chunk_compression_us(bags['lz4'].bag, bags['lz4'].final_step)
        floor_mb = lossless_floor_mb(bags['lz4'].bag)

        progress(f'{PFC_SCENARIO} recorded, {pfc_s} s sim')
        pfc_run = run_graph(pfc, tmp / 'pfc', domain, True)

        progress(f'recorder alone, {memory_s} s of sim time of synthetic blocks')
        hwm, feed_wall, fed = recorder_memory(bags['lz4'].bag, tmp / 'memory_bag', domain, memory_s,
                                              args.feed_rate, bag_scenario)

    recorded_rate, bare_rate = recorded.samples_per_second, bare.samples_per_second
    overhead = 100 * (recorded.wall_time / bare.wall_time - 1)
    pipelined = delayed['pipelined']
    rows = [
        ('project ceiling (raw_responder, wait sets)', f'{ceiling:.0f} round trips/s', '', ''),
        ('naive ceiling (callback, SingleThreadedExecutor)', f'{naive:.0f} round trips/s', '', ''),
        (f'default graph recorded ({DEFAULT})', f'{recorded_rate:.0f} samples/s', '', ''),
        ('  / project ceiling', f'{recorded_rate / ceiling:.2f}', '>= 0.90', goal(recorded_rate >= 0.9 * ceiling)),
        ('  / naive ceiling', f'{recorded_rate / naive:.2f}', '>= 1.00', goal(recorded_rate >= naive)),
        ('default graph unrecorded', f'{bare_rate:.0f} samples/s', '', ''),
        ('recording adds (wall time), viewer topics included', f'{overhead:+.1f} %', '< 8 %', goal(overhead < 8)),
        ('computation_delay on, sequential (plant+fixed_responder)', f'{delayed["sequential"]:.0f} samples/s',
         '', ''),
        ('computation_delay on, pipelined', f'{pipelined:.0f} samples/s', '', ''),
        ('  pipelined / project ceiling', f'{pipelined / ceiling:.2f}', '>= 1.40', goal(pipelined >= 1.4 * ceiling)),
        ('  pipelined / sequential', f'{pipelined / delayed["sequential"]:.2f}', '', ''),
        ('bag at 25 us, messages uncompressed',
         f'{compression_cost["raw MB"] / bags["lz4"].final_time:.1f} MB/sim s', '', ''),
    ]
    for compression, run in bags.items():
        per_s = run.bag_mb / run.final_time
        rows.append((f'bag at 25 us, {compression}', f'{per_s:.1f} MB/sim s', '<= 6', goal(per_s <= 6)))
        rows.append((f'  recorder CPU per sample, {compression}', f'{run.cpu_us["recorder"]:.0f} us', '', ''))
        rows.append((f'  of it chunk compression, {compression}', f'{compression_cost[compression]:.1f} us', '', ''))
    rows.append(('  lossless floor (XOR delta, byte planes, zstd 19)',
                 f'{floor_mb / bags["lz4"].final_time:.1f} MB/sim s', '', ''))
    pfc_rate = pfc_run.samples_per_second
    rows.append((f'{PFC_SCENARIO} recorded (4 processes)', f'{pfc_rate:.0f} samples/s',
                 f'>= {2 * PFC_TODAY:.0f}', goal(pfc_rate >= 2 * PFC_TODAY)))
    fed_ok = all(got == want for got, want in fed.values())
    rows.append((f'recorder peak memory, {memory_s:g} s sim at 25 us', f'{hwm:.0f} MB', '< 300',
                 goal(hwm < 300)))
    width = max(len(r[0]) for r in rows)
    print(f'{"figure":{width}s}  {"measured":>20s}  {"goal":>9s}  result')
    for name, value, target, result in rows:
        print(f'{name:{width}s}  {value:>20s}  {target:>9s}  {result}')
    print()
    for label, run in (('default recorded', recorded), ('default unrecorded', bare),
                       (f'{PFC_SCENARIO} recorded', pfc_run)):
        per = run.cpu_us
        print(f'CPU per sample, {label}: ' + ', '.join(f'{k} {v:.0f} us' for k, v in per.items())
              + f'; total {sum(per.values()):.0f} us')
    print(f'runs: default {recorded.final_step} samples ({default.duration} s sim at '
          f'{1e6 * recorded.final_time / max(recorded.final_step, 1):.1f} us), median of {repeats}; '
          f'computation_delay {samples} samples, best of {repeats}; '
          f'{BAG_SCENARIO} {bags["lz4"].final_step} samples; {PFC_SCENARIO} {pfc_run.final_step} samples')
    print('default recorded bag: ' + ', '.join(f'{t} {n} samples in {m} blocks'
                                               for t, (n, m) in default_blocks.items()))
    print(f'completeness: default recorded {"every sample" if not default_lost else default_lost}; '
          + '; '.join(f'{c} {"every sample" if not r.lost else r.lost}' for c, r in bags.items())
          + f'; synthetic feed {"every sample" if fed_ok else fed} '
          f'({feed_wall:.1f} s wall, {args.feed_rate:.0f} samples/s asked)')
    if any(hung.values()):
        print(f'computation_delay runs whose Run goal hung (> 60 s, left out): {hung}')
    print(f'whole benchmark: {time.perf_counter() - began:.0f} s wall')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
