"""A launch-free script that drives a running plant through its ``plant/run`` action.

``ros2 run drive_examples scripted_run --to 0.02 --then 0.01``: the plant runs to t = 0.02 s,
holds, then runs 0.01 s more (a relative goal); each result is printed.
"""
from __future__ import annotations

import argparse
import sys


def main(argv=None) -> int:
    import rclpy
    from rclpy.action import ActionClient
    from rclpy.executors import SingleThreadedExecutor

    from drive_common.node_main import destroy_node_and_actions, spin_in_background
    from drive_common.run_goal import run_to
    from dtc_msgs.action import Run

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--to', type=float, required=True, help='absolute target, s of sim time')
    parser.add_argument('--then', type=float, default=0.0, help='then this many s more (0: no second goal)')
    args = parser.parse_args(rclpy.utilities.remove_ros_args(sys.argv if argv is None else argv)[1:])

    rclpy.init(args=argv)
    node = rclpy.create_node('scripted_run')
    executor = SingleThreadedExecutor()
    executor.add_node(node)

    spinner = spin_in_background(executor)     # run_to polls; this thread spins the node
    try:
        plant = ActionClient(node, Run, 'plant/run')
        if not plant.wait_for_server(timeout_sec=30.0):
            print('no plant/run action server within 30 s', file=sys.stderr)
            return 1
        results = [run_to(plant, args.to)]
        if args.then > 0.0:
            results.append(run_to(plant, args.then, relative=True))
        for result in results:
            print(f'success={result.success} final_step={result.final_step} '
                  f'final_time={result.final_time:.6f} {result.message}', flush=True)
        return 0 if all(r.success for r in results) else 1
    finally:
        rclpy.try_shutdown()        # ends the spin, then the node goes
        spinner.join(timeout=10.0)
        destroy_node_and_actions(node)     # the action client too: it would keep the node


if __name__ == '__main__':
    sys.exit(main())
