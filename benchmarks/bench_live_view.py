"""What the Foxglove live view costs a run: the default scenario, unrecorded, three ways.

1. the graph alone;
2. the graph + drive_logger live_view, nobody connected (the decimation cost:
   its subscriptions to the per-sample topics and its own CPU);
3. the graph + live_view + a viewer (a websockets client subscribed to every
   channel and reading, as the Foxglove app would).

Prints samples per wall second of the Run goals (median of --repeats) and
the ratios; the goal is 3 ~= 2 (a viewer costs no more than the decimation).
On a shared machine the wall rates vary a lot; each process's CPU time per
sample during the Run goals (from /proc/<pid>/stat) varies much less.
Each variant runs in its own private DDS domain; the live view listens on a
free port.

    source scripts/env.sh && python benchmarks/bench_live_view.py [--duration 0.2] [--repeats 3]
"""
from __future__ import annotations

import argparse
import json
import re
import statistics
import tempfile
import threading
from pathlib import Path

from bench_scenario_ros import cpu_seconds  # benchmarks/bench_scenario_ros.py
from drive_bringup.runner import GraphRunner
from drive_bringup.scenario import find_scenario, load_scenario
from drive_common.waiting import wait_until
from drive_testing.harness import reserve_domain

DEFAULT = 'two_phase_six_switch_torque_step'


class Viewer(threading.Thread):
    """Subscribes to every advertised channel and reads until stopped; counts data frames."""

    def __init__(self, port: int) -> None:
        super().__init__(daemon=True)
        self.port, self.frames = port, 0
        self.subscribed, self.stop = threading.Event(), threading.Event()

    def run(self) -> None:
        from websockets.sync.client import connect
        with connect(f'ws://127.0.0.1:{self.port}', subprotocols=['foxglove.sdk.v1']) as ws:
            while not self.stop.is_set():
                try:
                    frame = ws.recv(timeout=0.2)
                except TimeoutError:
                    continue
                if isinstance(frame, str):
                    message = json.loads(frame)
                    if message['op'] == 'advertise':
                        ws.send(json.dumps({'op': 'subscribe', 'subscriptions': [
                            {'id': c['id'], 'channelId': c['id']} for c in message['channels']]}))
                        self.subscribed.set()
                elif frame[0] == 1:
                    self.frames += 1


class LiveRunner(GraphRunner):
    """GraphRunner whose live view listens on a free port, optionally with a viewer connected."""

    def __init__(self, *args, viewer: bool = False, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.with_viewer, self.viewer = viewer, None

    def _start(self, key, package, executable, parameters, node_name=None):
        if key == 'live_view':
            parameters = {**parameters, 'port': 0}
        return super()._start(key, package, executable, parameters, node_name=node_name)

    def _wait_ready(self, *args):
        super()._wait_ready(*args)
        if 'live_view' not in self.processes:
            return
        live = self.processes['live_view']
        match = wait_until(lambda: re.search(r'live view ready: ws://[\d.]+:(\d+)', live.output()),
                           60.0, 0.05, 'live_view ready')
        if self.with_viewer:
            self.viewer = Viewer(int(match.group(1)))
            self.viewer.start()
            if not self.viewer.subscribed.wait(30.0):
                raise RuntimeError('the viewer did not subscribe')

    def _drive(self, node, executor, bag_dir):
        start = {k: cpu_seconds(p.pid) for k, p in self.processes.items()}
        result = super()._drive(node, executor, bag_dir)
        self.cpu_us_per_sample = {k: (cpu_seconds(p.pid) - start[k]) / result.final_step * 1e6
                                  for k, p in self.processes.items()}
        return result

    def _stop_all(self):
        if self.viewer is not None:
            self.viewer.stop.set()
            self.viewer.join(timeout=5.0)
        super()._stop_all()


def run_once(scenario, live: bool, viewer: bool) -> tuple[float, int, dict]:
    with reserve_domain() as domain, tempfile.TemporaryDirectory() as out:
        runner = LiveRunner(scenario, Path(out), domain_id=domain, record=False, live=live,
                            viewer=viewer, progress=lambda _msg: None)
        result = runner.run()
        return result.samples_per_second, runner.viewer.frames if runner.viewer else 0, runner.cpu_us_per_sample


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--scenario', default=DEFAULT)
    parser.add_argument('--duration', type=float, default=0.2, help='sim seconds per run')
    parser.add_argument('--repeats', type=int, default=3, help='runs of each variant (median)')
    args = parser.parse_args()
    scenario = load_scenario(find_scenario(args.scenario)).with_duration(args.duration)
    variants = {'graph alone': (False, False), 'live_view, no viewer': (True, False),
                'live_view + reading viewer': (True, True)}
    rates: dict[str, list[float]] = {name: [] for name in variants}
    cpu: dict[str, list[dict]] = {name: [] for name in variants}
    frames = []
    for _ in range(args.repeats):               # interleaved, so machine load hits every variant alike
        for name, (live, viewer) in variants.items():
            rate, got, cpu_us = run_once(scenario, live, viewer)
            rates[name].append(rate)
            cpu[name].append(cpu_us)
            if viewer:
                frames.append(got)
    medians = {name: statistics.median(values) for name, values in rates.items()}
    base = medians['graph alone']
    print(f'{scenario.name}, {args.duration} s sim, unrecorded, median of {args.repeats}:')
    for name, value in medians.items():
        print(f'  {name:28s} {value:8.0f} samples/s  ({value / base:.2f} of the graph alone)  '
              f'runs: {", ".join(f"{v:.0f}" for v in rates[name])}')
    print('CPU time per sample (us, median), per process:')
    for name in variants:
        keys = cpu[name][0]
        per = {k: statistics.median(run[k] for run in cpu[name]) for k in keys}
        print(f'  {name:28s} ' + ', '.join(f'{k} {v:.0f}' for k, v in per.items())
              + f'; total {sum(per.values()):.0f}')
    print(f'  viewer received {statistics.median(frames):.0f} data frames per run (median)')
    ratio = medians['live_view + reading viewer'] / medians['live_view, no viewer']
    print(f'  a reading viewer vs none: {ratio:.2f} (goal: about 1, a viewer costs no more than the decimation)')


if __name__ == '__main__':
    main()
