"""``ros2 topic list|echo|hz|info|pub``."""
from __future__ import annotations

import math
import time

from drive_ros2cli import messages
from drive_ros2cli.client import DEFAULT_TIMEOUT, CliNode, absolute_name, print_names_and_types
from drive_ros2cli.errors import CliError
from drive_ros2cli.verbs import add_verb

DESCRIPTION = 'Various topic related sub-commands'


def add_verbs(verbs) -> None:
    p = add_verb(verbs, 'list', list_main, 'Output a list of available topics', graph=True)
    p.add_argument('-t', '--show-types', action='store_true', help='Additionally show the topic type')
    p.add_argument('-c', '--count-topics', action='store_true', help='Only display the number of topics discovered')
    p.add_argument('--include-hidden-topics', action='store_true', help='Consider hidden topics as well')

    p = add_verb(verbs, 'echo', echo_main, 'Output messages from a topic', graph=True)
    p.add_argument('topic_name', help="Name of the ROS topic to listen to (e.g. '/chatter')")
    p.add_argument('message_type', nargs='?', help="Type of the ROS message (e.g. 'std_msgs/msg/String')")
    p.add_argument('--once', action='store_true', help='Print the first message received and then exit')
    p.add_argument('--field', type=str, help="Echo a selected field of a message. Use '.' to select sub-fields.")
    p.add_argument('--timeout', type=float, default=None,
                   help='Time in seconds to wait for a message with --once (default: until Ctrl-C)')
    p.add_argument('--no-arr', action='store_true', help="Don't print array fields of messages")
    p.add_argument('--no-str', action='store_true', help="Don't print string fields of messages")

    p = add_verb(verbs, 'hz', hz_main, 'Print the average publishing rate to screen',
                 description='Print the average receiving rate to screen', graph=True)
    p.add_argument('topic_name', help="Name of the ROS topic to listen to (e.g. '/chatter')")
    p.add_argument('-w', '--window', type=int, default=10000, metavar='WINDOW',
                   help='window size, in # of messages, for calculating rate (default: %(default)s)')
    p.add_argument('--wall-time', action='store_true', help='calculates rate using wall time')

    p = add_verb(verbs, 'info', info_main, 'Print information about a topic', graph=True)
    p.add_argument('topic_name', help="Name of the ROS topic to get info (e.g. '/chatter')")
    p.add_argument('-v', '--verbose', action='store_true',
                   help='Prints detailed information like the node name, node namespace, topic type, '
                        'topic type hash, GUID, and QoS Profile of the publishers and subscribers to this topic')

    p = add_verb(verbs, 'pub', pub_main, 'Publish a message to a topic', graph=True)
    p.add_argument('topic_name', help="Name of the ROS topic to publish to (e.g. '/chatter')")
    p.add_argument('message_type', help="Type of the ROS message (e.g. 'std_msgs/String')")
    p.add_argument('values', nargs='?', default='{}',
                   help="Values to fill the message with in YAML format (e.g. 'data: Hello World')")
    p.add_argument('-r', '--rate', type=float, default=1.0, metavar='N',
                   help='Publishing rate in Hz (default: %(default)s)')
    p.add_argument('-p', '--print', type=int, default=1, metavar='N', dest='print_nth',
                   help='Only print every N-th published message (default: %(default)s)')
    group = p.add_mutually_exclusive_group()
    group.add_argument('-1', '--once', action='store_true', help='Publish one message and exit')
    group.add_argument('-t', '--times', type=int, default=0, metavar='N',
                       help='Publish this number of times and then exit')
    p.add_argument('-w', '--wait-matching-subscriptions', type=int, default=None, metavar='N',
                   help='Wait until finding the specified number of matching subscriptions '
                        '(default: 1 with --once or --times, else 0; at most --max-wait-time-secs)')
    p.add_argument('--max-wait-time-secs', type=float, default=DEFAULT_TIMEOUT,
                   help='Longest time to wait for matching subscriptions (default: %(default)s)')
    p.add_argument('--keep-alive', type=float, default=0.1, metavar='N',
                   help='Keep publishing node alive for N seconds after the last msg (default: %(default)s)')
    p.add_argument('-n', '--node-name', help='Name of the created publishing node')


def list_main(args) -> int:
    with CliNode(args) as cli:
        topics = cli.topics(include_hidden=args.include_hidden_topics)
    return print_names_and_types(topics, args.count_topics, args.show_types)


def _topic_type(cli: CliNode, topic: str, given: str | None, wait: float) -> str:
    if given:
        return given
    types = cli.wait_for(lambda: dict(cli.node.get_topic_names_and_types()).get(topic), wait)
    if not types:
        raise CliError('Could not determine the type for the passed topic')
    if len(types) > 1:
        raise CliError(f"Cannot echo topic '{topic}', as it contains more than one type: "
                       f"[{', '.join(types)}]")
    return types[0]


def _subscription_qos(cli: CliNode, topic: str):
    """Reliable/transient-local only when every publisher offers it (upstream's auto-detection)."""
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    qos = QoSProfile(depth=10)
    offered = [info.qos_profile for info in cli.node.get_publishers_info_by_topic(topic)]
    if offered and all(q.reliability == ReliabilityPolicy.RELIABLE for q in offered):
        qos.reliability = ReliabilityPolicy.RELIABLE
    else:
        qos.reliability = ReliabilityPolicy.BEST_EFFORT
    if offered and all(q.durability == DurabilityPolicy.TRANSIENT_LOCAL for q in offered):
        qos.durability = DurabilityPolicy.TRANSIENT_LOCAL
    return qos


def _strip(value, no_arr: bool, no_str: bool):
    if isinstance(value, dict):
        out = {}
        for key, item in value.items():
            if no_arr and isinstance(item, list):
                out[key] = f'<sequence type: , length: {len(item)}>'
            elif no_str and isinstance(item, str):
                out[key] = '<string length: <{}>>'.format(len(item))
            else:
                out[key] = _strip(item, no_arr, no_str)
        return out
    return value


def _select_field(msg, field: str | None):
    if not field:
        return msg
    value = msg
    for part in field.split('.'):
        if not messages.is_message(value) or part not in value.get_fields_and_field_types():
            raise CliError(f"Invalid field '{field}': {type(msg).__name__} has no such field")
        value = getattr(value, part)
    return value


def echo_main(args) -> int:
    topic = absolute_name(args.topic_name)
    with CliNode(args) as cli:
        cli.discover()
        msg_class = messages.interface_class(_topic_type(cli, topic, args.message_type, DEFAULT_TIMEOUT))
        if args.field:
            _select_field(msg_class(), args.field)      # a wrong field fails before waiting
        received = []

        def on_message(msg) -> None:
            value = _select_field(msg, args.field)
            plain = _strip(messages.to_plain(value), args.no_arr, args.no_str)
            print(messages.to_yaml(plain), end='---\n', flush=True)
            received.append(True)

        cli.node.create_subscription(msg_class, topic, on_message, _subscription_qos(cli, topic))
        if args.once:
            timeout = math.inf if args.timeout is None else args.timeout
            if not cli.wait_for(lambda: received, timeout):
                raise CliError(f"No message received on '{topic}' within {args.timeout:g} s")
            return 0
        while True:
            cli.spin_for(1.0)


def hz_main(args) -> int:
    topic = absolute_name(args.topic_name)
    with CliNode(args) as cli:
        cli.discover()
        msg_class = messages.interface_class(_topic_type(cli, topic, None, DEFAULT_TIMEOUT))
        stamps: list[float] = []

        def on_message(_msg) -> None:
            now = (time.monotonic() if args.wall_time
                   else cli.node.get_clock().now().nanoseconds * 1e-9)
            stamps.append(now)
            del stamps[:-(args.window + 1)]

        cli.node.create_subscription(msg_class, topic, on_message, _subscription_qos(cli, topic))
        last_printed = None
        while True:
            cli.spin_for(1.0)
            if len(stamps) < 2 or stamps[-1] == last_printed:
                continue
            last_printed = stamps[-1]
            periods = [b - a for a, b in zip(stamps, stamps[1:])]
            mean = sum(periods) / len(periods)
            if mean <= 0:
                continue
            std = math.sqrt(sum((p - mean) ** 2 for p in periods) / len(periods))
            print(f'average rate: {1.0 / mean:.3f}\n\tmin: {min(periods):.3f}s max: {max(periods):.3f}s '
                  f'std dev: {std:.5f}s window: {len(stamps)}', flush=True)


def info_main(args) -> int:
    topic = absolute_name(args.topic_name)
    end = '\n\n' if args.verbose else '\n'
    with CliNode(args) as cli:
        types = cli.wait_for_name(lambda: dict(cli.topics(include_hidden=True)).get(topic))
        if not types:
            raise CliError(f"Unknown topic '{topic}'")
        node = cli.node
        print(f"Type: {', '.join(types)}", end=end)
        for kind, count, endpoints in (
                ('Publisher', node.count_publishers, node.get_publishers_info_by_topic),
                ('Subscription', node.count_subscribers, node.get_subscriptions_info_by_topic)):
            print(f'{kind} count: {count(topic)}', end=end)
            for info in endpoints(topic) if args.verbose else ():
                print(info, end=end)
    return 0


def pub_main(args) -> int:
    from rclpy.qos import QoSProfile
    topic = absolute_name(args.topic_name)
    msg_class = messages.interface_class(args.message_type)
    msg = messages.fill(msg_class(), messages.parse_values(args.values))
    times = 1 if args.once else args.times
    if args.rate <= 0 and times != 1:
        raise CliError('rate must be greater than zero')
    wait_for = args.wait_matching_subscriptions
    if wait_for is None:
        wait_for = 1 if times else 0
    with CliNode(args, name=args.node_name or 'ros2cli_pub') as cli:
        publisher = cli.node.create_publisher(msg_class, topic, QoSProfile(depth=10))
        if wait_for:
            print('Waiting for at least '
                  f"{wait_for} matching subscription(s)...", flush=True)
            cli.wait_for(lambda: publisher.get_subscription_count() >= wait_for, args.max_wait_time_secs)
        print('publisher: beginning loop', flush=True)
        count = 0
        period = 1.0 / args.rate if args.rate > 0 else 0.0
        next_time = time.monotonic()
        while True:
            publisher.publish(msg)
            count += 1
            if args.print_nth and count % args.print_nth == 0:
                print(f'publishing #{count}: {msg!r}\n', flush=True)
            if times and count >= times:
                cli.spin_for(args.keep_alive)
                return 0
            next_time += period
            cli.spin_for(max(0.0, next_time - time.monotonic()))
