"""A minimal ``ros2`` command for the embedded (PyPI-wheel) set-up.

The ROS 2 wheels ship no ros2cli. ``scripts/setup.sh`` installs this shim
as ``.venv/bin/ros2`` when no real ``ros2`` exists, covering what the drive
stack's users need day to day; with a system ROS the real ``ros2`` is used.

    ros2 run <package> <executable> [args...]        # exec lib/<package>/<executable>
    ros2 param list <node>
    ros2 param get <node> <name>
    ros2 param set <node> <name> <value>              # value parsed as YAML
    ros2 topic list
"""
from __future__ import annotations

import os
import sys

import yaml

USAGE = __doc__.split('\n\n')[1]


def _with_node(fn):
    import rclpy
    rclpy.init()
    node = rclpy.create_node('ros2_shim_client')
    try:
        return fn(node)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


def _param_client(node, target: str):
    from rclpy.parameter_client import AsyncParameterClient
    client = AsyncParameterClient(node, target if target.startswith('/') else '/' + target)
    if not client.wait_for_services(timeout_sec=10.0):
        raise SystemExit(f'node {target} not found (no parameter services within 10 s)')
    return client


def _wait(node, future):
    import rclpy
    rclpy.spin_until_future_complete(node, future, timeout_sec=10.0)
    if not future.done():
        raise SystemExit('no answer within 10 s')
    return future.result()


def param_command(argv: list[str]) -> int:
    from rclpy.parameter import Parameter, parameter_value_to_python
    if len(argv) < 2:
        print(USAGE, file=sys.stderr)
        return 2
    verb, target = argv[0], argv[1]

    def run(node) -> int:
        client = _param_client(node, target)
        if verb == 'list':
            for name in sorted(_wait(node, client.list_parameters()).result.names):
                print(f'  {name}')
            return 0
        if verb == 'get' and len(argv) == 3:
            values = _wait(node, client.get_parameters([argv[2]])).values
            print(parameter_value_to_python(values[0]))
            return 0
        if verb == 'set' and len(argv) == 4:
            value = yaml.safe_load(argv[3])
            result = _wait(node, client.set_parameters([Parameter(argv[2], value=value)])).results[0]
            if result.successful:
                print('Set parameter successful')
                return 0
            print(f'Setting parameter failed: {result.reason}')
            return 1
        print(USAGE, file=sys.stderr)
        return 2

    return _with_node(run)


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ('-h', '--help'):
        print(USAGE)
        return 0
    if argv[0] == 'run' and len(argv) >= 3:
        from drive_common.processes import executable_path
        try:
            path = executable_path(argv[1], argv[2])
        except FileNotFoundError as exc:
            print(f'ros2 run: {exc}', file=sys.stderr)
            return 1
        os.execv(str(path), [str(path), *argv[3:]])
    if argv[0] == 'param':
        return param_command(argv[1:])
    if argv[0] == 'topic' and argv[1:] == ['list']:
        def run(node) -> int:
            import time
            time.sleep(1.0)  # discovery
            for name, types in sorted(node.get_topic_names_and_types()):
                print(name)
            return 0
        return _with_node(run)
    print(USAGE, file=sys.stderr)
    return 2


if __name__ == '__main__':
    raise SystemExit(main())
