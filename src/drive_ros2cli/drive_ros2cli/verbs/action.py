"""``ros2 action list|info|send_goal``."""
from __future__ import annotations

from drive_common.action_goals import goal_result, send_goal, within
from drive_common.namespaces import full_name
from drive_ros2cli import messages
from drive_ros2cli.client import DEFAULT_TIMEOUT, CliNode, absolute_name, print_names_and_types
from drive_ros2cli.errors import CliError
from drive_ros2cli.verbs import add_verb

DESCRIPTION = 'Various action related sub-commands'
STATUS = {0: 'UNKNOWN', 1: 'ACCEPTED', 2: 'EXECUTING', 3: 'CANCELING', 4: 'SUCCEEDED',
          5: 'CANCELED', 6: 'ABORTED'}


def add_verbs(verbs) -> None:
    p = add_verb(verbs, 'list', list_main, 'Output a list of action names', graph=True)
    p.add_argument('-t', '--show-types', action='store_true', help='Additionally show the action type')
    p.add_argument('-c', '--count-actions', action='store_true', help='Only display the number of actions discovered')

    p = add_verb(verbs, 'info', info_main, 'Print information about an action', graph=True)
    p.add_argument('action_name', help="Name of the ROS action to get info (e.g. '/fibonacci')")
    p.add_argument('-t', '--show-types', action='store_true', help='Additionally show the action type')
    p.add_argument('-c', '--count', action='store_true', help='Only display the number of action clients and servers')

    p = add_verb(verbs, 'send_goal', send_goal_main, 'Send an action goal', graph=True)
    p.add_argument('action_name', help="Name of the ROS action (e.g. '/fibonacci')")
    p.add_argument('action_type', help="Type of the ROS action (e.g. 'example_interfaces/action/Fibonacci')")
    p.add_argument('goal', nargs='?', default='{}', help="Goal request values in YAML format (e.g. '{order: 10}')")
    p.add_argument('-f', '--feedback', action='store_true', help='Echo feedback messages for the goal')
    p.add_argument('--timeout', type=float, default=DEFAULT_TIMEOUT, metavar='N',
                   help='Seconds to wait for the action server, and for the goal response per attempt: a reply lost right after discovery is recovered from the status topic, the goal is never sent twice (default %(default)s)')
    p.add_argument('--result-timeout', type=float, default=None, metavar='N',
                   help='Seconds to wait for the result (default: until Ctrl-C)')


def _actions(cli: CliNode) -> list:
    from rclpy.action.graph import get_action_names_and_types
    cli.discover()
    return sorted(get_action_names_and_types(cli.node))


def list_main(args) -> int:
    with CliNode(args) as cli:
        actions = _actions(cli)
    return print_names_and_types(actions, args.count_actions, args.show_types)


def info_main(args) -> int:
    from rclpy.action.graph import (get_action_client_names_and_types_by_node,
                                    get_action_server_names_and_types_by_node)
    name = absolute_name(args.action_name)
    with CliNode(args) as cli:
        if not cli.wait_for_name(lambda: name in dict(_actions(cli))):
            raise CliError(f"Unknown action '{name}'")
        clients, servers = [], []
        for node_name, namespace in cli.node.get_node_names_and_namespaces():
            full = full_name(node_name, namespace)
            for found, lookup in ((clients, get_action_client_names_and_types_by_node),
                                  (servers, get_action_server_names_and_types_by_node)):
                for action, types in lookup(cli.node, node_name, namespace):
                    if action == name:
                        found.append((full, types))
    print(f'Action: {name}')
    for title, found in (('Action clients', clients), ('Action servers', servers)):
        print(f'{title}: {len(found)}')
        if not args.count:
            for full, types in sorted(found):
                print(f"    {full} [{', '.join(types)}]" if args.show_types else f'    {full}')
    return 0


def send_goal_main(args) -> int:
    from rclpy.action import ActionClient
    name = absolute_name(args.action_name)
    action_class = messages.interface_class(args.action_type, default_kind='action')
    goal = messages.fill(action_class.Goal(), messages.parse_values(args.goal))
    with CliNode(args) as cli:
        client = ActionClient(cli.node, action_class, name)
        print('Waiting for an action server to become available...', flush=True)
        if not cli.wait_for(client.server_is_ready, args.timeout):
            raise CliError(f"Action server '{name}' not available within {args.timeout:g} s")
        print(f'Sending goal:\n     {messages.to_yaml(goal)}', flush=True)

        def on_feedback(feedback) -> None:
            print(f'Feedback:\n    {messages.to_yaml(feedback.feedback)}', flush=True)

        try:         # a reply lost right after discovery is recovered, the goal never sent twice
            handle = send_goal(client, goal, wait=cli.wait_for, response_wait=args.timeout,
                               feedback=on_feedback if args.feedback else None)
        except TimeoutError as exc:
            raise CliError(f"goal request to '{name}': {exc}") from None
        if not handle.accepted:
            print('Goal was rejected.')
            return 0
        print(f"Goal accepted with ID: {bytes(handle.goal_id.uuid).hex()}\n", flush=True)
        try:
            timeout = args.result_timeout if args.result_timeout is not None else float('inf')
            result = goal_result(handle, wait=within(cli.wait_for, timeout))
            if result is None:
                raise CliError(f"result of the goal on '{name}': no answer within {timeout:g} s")
        except KeyboardInterrupt:
            print('Canceling goal...')
            cli.call(handle.cancel_goal_async(), args.timeout, 'goal cancel request')
            raise
        print(f'Result:\n    {messages.to_yaml(result.result)}')
        print(f'Goal finished with status: {STATUS.get(result.status, result.status)}')
    return 0
