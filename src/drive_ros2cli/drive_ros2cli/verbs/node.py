"""``ros2 node list|info``: the graph's nodes and what each publishes, subscribes and serves."""
from __future__ import annotations

from drive_ros2cli.client import CliNode, is_hidden, split_node_name
from drive_ros2cli.verbs import add_verb

DESCRIPTION = 'Various node related sub-commands'


def add_verbs(verbs) -> None:
    p = add_verb(verbs, 'list', list_main, 'Output a list of available nodes', graph=True)
    p.add_argument('-a', '--all', action='store_true', help='Display all nodes even hidden ones')
    p.add_argument('-c', '--count-nodes', action='store_true',
                   help='Only display the number of nodes discovered')

    p = add_verb(verbs, 'info', info_main, 'Output information about a node', graph=True)
    p.add_argument('node_name', help='Node name to request information')
    p.add_argument('--include-hidden', action='store_true', help='Display hidden topics, services, and actions as well')


def list_main(args) -> int:
    with CliNode(args) as cli:
        names = cli.node_names(include_hidden=args.all)
    if args.count_nodes:
        print(len(names))
    else:
        for name in names:
            print(name)
    return 0


def _print_section(title: str, names_and_types, include_hidden: bool) -> None:
    print(f'  {title}:')
    lines = [f"    {name}: {', '.join(types)}" for name, types in sorted(names_and_types)
             if include_hidden or not is_hidden(name)]
    print(*lines, sep='\n')     # an empty section prints one empty line, as upstream


def info_main(args) -> int:
    from rclpy.action.graph import (get_action_client_names_and_types_by_node,
                                    get_action_server_names_and_types_by_node)
    with CliNode(args) as cli:
        full_name = cli.require_node(args.node_name, include_hidden=True)
        name, namespace = split_node_name(full_name)
        node = cli.node
        sections = (
            ('Subscribers', node.get_subscriber_names_and_types_by_node(name, namespace)),
            ('Publishers', node.get_publisher_names_and_types_by_node(name, namespace)),
            ('Service Servers', node.get_service_names_and_types_by_node(name, namespace)),
            ('Service Clients', node.get_client_names_and_types_by_node(name, namespace)),
            ('Action Servers', get_action_server_names_and_types_by_node(node, name, namespace)),
            ('Action Clients', get_action_client_names_and_types_by_node(node, name, namespace)),
        )
    print(full_name)
    for title, names_and_types in sections:
        _print_section(title, names_and_types, args.include_hidden)
    return 0
