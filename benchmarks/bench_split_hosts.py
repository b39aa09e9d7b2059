"""Lockstep rate with the graph split across hosts vs on one host.

Runs the default scenario (plant + dtc_controller + recorder, recorded)
alternately
1. on one host: every node in this machine's network namespace, private
   domain, localhost discovery (Fast DDS then uses shared memory);
2. split: plant, controller and supervisor (recorder + runner) in three
   network namespaces on one bridge (drive_bringup.split_hosts): every
   lockstep message crosses a veth link as UDP;
and prints the samples per wall second of the Run goals (median of
--repeats runs each; start-up and analysis excluded) and the ratio. Needs
root (network namespaces).

    source scripts/env.sh && python benchmarks/bench_split_hosts.py [--duration 0.1] [--repeats 3]
"""
from __future__ import annotations

import argparse
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from drive_common.netns import unavailable_reason

DEFAULT = 'two_phase_six_switch_torque_step'
RATE = re.compile(r'done: .* \((\d+) samples/s\)')


def rate(module: str, scenario: str, duration: float, out: Path) -> float:
    result = subprocess.run([sys.executable, '-m', module, scenario, '--duration', str(duration),
                             '--out', str(out), *(['--isolate'] if module.endswith('runner_cli') else [])],
                            capture_output=True, text=True, timeout=1800)
    found = RATE.search(result.stdout)
    if result.returncode != 0 or not found:
        raise SystemExit(f'{module} failed ({result.returncode}):\n{result.stdout}\n{result.stderr}')
    return float(found.group(1))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--scenario', default=DEFAULT)
    parser.add_argument('--duration', type=float, default=0.1, help='sim time per run (s)')
    parser.add_argument('--repeats', type=int, default=3)
    args = parser.parse_args()
    reason = unavailable_reason()
    if reason:
        print(f'bench_split_hosts: {reason}', file=sys.stderr)
        return 2
    rates: dict[str, list[float]] = {'one host': [], 'split (veth, UDP)': []}
    with tempfile.TemporaryDirectory(prefix='bench_split_') as tmp:
        for i in range(args.repeats):
            rates['one host'].append(rate('drive_bringup.runner_cli', args.scenario, args.duration,
                                          Path(tmp) / f'single{i}'))
            rates['split (veth, UDP)'].append(rate('drive_bringup.split_hosts', args.scenario,
                                                   args.duration, Path(tmp) / f'split{i}'))
    print(f'{args.scenario}, {args.duration} s sim per run, recorded, median of {args.repeats}:')
    medians = {name: statistics.median(values) for name, values in rates.items()}
    for name, values in rates.items():
        print(f'  {name:20s} {medians[name]:7.0f} samples/s  (runs: '
              + ', '.join(f'{v:.0f}' for v in values) + ')')
    print(f'  split / one host     {medians["split (veth, UDP)"] / medians["one host"]:.2f}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
