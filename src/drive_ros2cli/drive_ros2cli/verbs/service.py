"""``ros2 service list|type|call``."""
from __future__ import annotations

from drive_ros2cli import messages
from drive_ros2cli.client import DEFAULT_TIMEOUT, CliNode, absolute_name, print_names_and_types
from drive_ros2cli.errors import CliError
from drive_ros2cli.verbs import add_verb

DESCRIPTION = 'Various service related sub-commands'


def add_verbs(verbs) -> None:
    p = add_verb(verbs, 'list', list_main, 'Output a list of available services', graph=True)
    p.add_argument('-t', '--show-types', action='store_true', help='Additionally show the service type')
    p.add_argument('-c', '--count-services', action='store_true',
                   help='Only display the number of services discovered')
    p.add_argument('--include-hidden-services', action='store_true', help='Consider hidden services as well')

    p = add_verb(verbs, 'type', type_main, 'Output a service\'s type', graph=True)
    p.add_argument('service_name', help="Name of the ROS service to get type (e.g. '/add_two_ints')")

    p = add_verb(verbs, 'call', call_main, 'Call a service', graph=True)
    p.add_argument('service_name', help="Name of the ROS service to call to (e.g. '/add_two_ints')")
    p.add_argument('service_type', nargs='?',
                   help="Type of the ROS service (e.g. 'std_srvs/srv/Empty'; default: the graph's)")
    p.add_argument('values', nargs='?', default='{}',
                   help="Values to fill the service request with in YAML format (e.g. '{a: 1, b: 2}')")
    p.add_argument('-r', '--rate', type=float, metavar='N',
                   help='Repeat the call at a specific rate in Hz')
    p.add_argument('--timeout', type=float, default=DEFAULT_TIMEOUT, metavar='N',
                   help='Seconds to wait for the service and for its response (default %(default)s)')


def list_main(args) -> int:
    with CliNode(args) as cli:
        services = cli.services(include_hidden=args.include_hidden_services)
    return print_names_and_types(services, args.count_services, args.show_types)


def type_main(args) -> int:
    name = absolute_name(args.service_name)
    with CliNode(args) as cli:
        types = cli.wait_for_name(lambda: dict(cli.services(include_hidden=True)).get(name))
    if not types:
        raise CliError(f"Unknown service '{name}'")
    for service_type in types:
        print(service_type)
    return 0


def call_main(args) -> int:
    name = absolute_name(args.service_name)
    with CliNode(args) as cli:
        service_type = args.service_type
        if not service_type:
            cli.discover()
            types = cli.wait_for(lambda: dict(cli.node.get_service_names_and_types()).get(name), args.timeout)
            if not types:
                raise CliError(f"Unknown service '{name}': pass its type")
            service_type = types[0]
        srv_class = messages.interface_class(service_type, default_kind='srv')
        request = messages.fill(srv_class.Request(), messages.parse_values(args.values))
        client = cli.node.create_client(srv_class, name)
        if not client.service_is_ready():
            print('waiting for service to become available...', flush=True)
            if not client.wait_for_service(timeout_sec=args.timeout):
                raise CliError(f"Service '{name}' not available within {args.timeout:g} s")
        period = 1.0 / args.rate if args.rate else None
        while True:
            print(f'requester: making request: {request!r}\n', flush=True)
            response = cli.call(client.call_async(request), args.timeout, f"service '{name}'")
            print(f'response:\n{response!r}\n', flush=True)
            if period is None:
                return 0
            cli.spin_for(period)
