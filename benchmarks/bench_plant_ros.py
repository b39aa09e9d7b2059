"""Plant through ROS vs the raw rclpy publish -> reply ceiling (its speed goal).

Both measured in the same run, same message types, private DDS domain:
1. ceiling: raw_responder answers DriveMeasurement with GateCommand and a
   probe publishes/awaits one at a time (drive_testing.ceiling);
2. plant: the plant node (six-switch BLDC, T_s = 25 us) driven by a Run goal
   against fixed_responder (a real lockstep controller with a trivial core).
3. with computation_delay on: the same plant, sequential (pipelined:=false)
   and pipelined (measurement k+1 goes out and the plant integrates
   while the controller computes; goal >= 1.4 x the ceiling), alternated
   --repeats times, best of each (on a shared machine one run is noise).
Prints samples per wall second for each and the ratios (goal >= 0.7).

    source scripts/env.sh && python benchmarks/bench_plant_ros.py [--samples 8000]
"""
from __future__ import annotations

import argparse
import itertools
import time

import rclpy
from rclpy.action import ActionClient

from drive_common import topics
from drive_testing.ceiling import measure_round_trips
from drive_testing.harness import NodeProcess, private_domain
from drive_common.waiting import wait_until
from drive_common.action_goals import within
from drive_common.run_goal import run_goal_result, send_run_goal
from dtc_msgs.action import Run

TS = 25e-6
_CLIENTS = itertools.count()   # one client node name per run (same context)


def plant_rate(context, env, samples: int, state_period: float, timeout: float = 120.0,
               **plant) -> float:
    """Plant samples per wall second against fixed_responder; TimeoutError if a Run goal hangs."""
    with NodeProcess('drive_testing', 'fixed_responder', env=env), \
            NodeProcess('bldc_plant_sim', 'plant', env=env,
                        parameters={'motor.file': 'ozturk_bldc', 'dc_link.voltage': 10.0,
                                    'state_period': state_period, **plant}):
        node = rclpy.create_node(f'bench_client_{next(_CLIENTS)}', context=context)
        executor = rclpy.executors.SingleThreadedExecutor(context=context)
        executor.add_node(node)
        client = ActionClient(node, Run, topics.RUN_ACTION)
        wait_until(lambda: (executor.spin_once(timeout_sec=0.05), client.server_is_ready())[1], 30.0)

        def spin_for(done, seconds: float) -> bool:
            return wait_until(done, seconds, 0.05, raise_timeout=False,
                              pause=lambda s: executor.spin_once(timeout_sec=s))

        def run(target: float) -> tuple[float, object]:
            start = time.perf_counter()
            try:
                handle = send_run_goal(client, target, wait=spin_for)
            except TimeoutError as exc:
                raise TimeoutError(f'{exc} ({plant})') from exc
            result = run_goal_result(handle, wait=within(spin_for, timeout))
            if result is None:
                raise TimeoutError(f'Run goal to {target} s: accepted, no result after {timeout} s '
                                   f'({plant})')
            return time.perf_counter() - start, result

        run(200 * TS)                                   # warm-up (matching, first samples)
        wall, result = run((200 + samples) * TS)
        assert result.success, result.message
        node.destroy_node()
        return samples / wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--samples', type=int, default=8000)
    parser.add_argument('--repeats', type=int, default=3,
                        help='alternated sequential/pipelined runs with computation_delay')
    args = parser.parse_args()
    with private_domain() as (_, context, env):
        with NodeProcess('drive_testing', 'raw_responder', env=env):
            ceiling = measure_round_trips(context, args.samples)
        every = plant_rate(context, env, args.samples, TS)
        delayed = {'sequential': 0.0, 'pipelined': 0.0}
        for _ in range(args.repeats):
            for mode in delayed:
                rate = plant_rate(context, env, args.samples, TS, computation_delay=True,
                                  pipelined=mode == 'pipelined')
                delayed[mode] = max(delayed[mode], rate)
        print(f'raw rclpy publish->reply ceiling : {ceiling:8.0f} round trips/s')
        print(f'plant + fixed_responder (state every sample): {every:8.0f} samples/s '
              f'= {every / ceiling:.2f} of the ceiling (goal >= 0.70)')
        for mode, rate in delayed.items():
            print(f'computation_delay on, {mode:10s} (best of {args.repeats}): {rate:8.0f} samples/s '
                  f'= {rate / ceiling:.2f} of the ceiling')
        print(f'pipelined / sequential (computation_delay on): '
              f'{delayed["pipelined"] / delayed["sequential"]:.2f} '
              f'(goal: pipelined >= 1.40 x the ceiling)')
        print(f'real-time factor at T_s = 25 us : {every * TS:.3f}')


if __name__ == '__main__':
    main()
