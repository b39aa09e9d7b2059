"""``ros2 param list|get|set|describe|dump|load`` through rclpy's AsyncParameterClient, every
call with a time-out; ``dump`` writes YAML that ``load`` reads back with the same types."""
from __future__ import annotations

import re
import sys

from drive_common.parameter_files import flatten
from drive_ros2cli.client import DEFAULT_TIMEOUT, CliNode, add_node_arguments
from drive_ros2cli.errors import CliError
from drive_ros2cli.yaml_values import dump_yaml, load_yaml
from drive_ros2cli.verbs import add_verb

DESCRIPTION = 'Various param related sub-commands'

TYPE_NAMES = {0: 'not set', 1: 'boolean', 2: 'integer', 3: 'double', 4: 'string', 5: 'byte array',
              6: 'boolean array', 7: 'integer array', 8: 'double array', 9: 'string array'}
GET_LABELS = {1: ('Boolean value is:', 'bool_value'), 2: ('Integer value is:', 'integer_value'),
              3: ('Double value is:', 'double_value'), 4: ('String value is:', 'string_value'),
              5: ('Byte values are:', 'byte_array_value'), 6: ('Boolean values are:', 'bool_array_value'),
              7: ('Integer values are:', 'integer_array_value'),
              8: ('Double values are:', 'double_array_value'),
              9: ('String values are:', 'string_array_value')}


def _common(p, node_required: bool = True) -> None:
    add_node_arguments(p)
    if node_required:
        p.add_argument('node_name', help='Name of the ROS node')
    p.add_argument('--include-hidden-nodes', action='store_true', help='Consider hidden nodes as well')
    p.add_argument('--timeout', metavar='N', type=float, default=DEFAULT_TIMEOUT,
                   help='Wait for N seconds until node becomes available (default %(default)s sec)')
    p.add_argument('--service-timeout', metavar='N', type=float, default=DEFAULT_TIMEOUT,
                   help='Maximum time to wait for service response in seconds (default %(default)s sec)')


def add_verbs(verbs) -> None:
    p = add_verb(verbs, 'list', list_main, 'Output a list of available parameters')
    _common(p, node_required=False)
    p.add_argument('node_name', nargs='?', help='Name of the ROS node')
    p.add_argument('--param-prefixes', nargs='+', default=[], help='Only list parameters with the provided prefixes')
    p.add_argument('--param-type', action='store_true', help='Print parameter types with parameter names')
    p.add_argument('--filter', metavar='FILTER_REGEX', help='Only list parameters matching the regex')

    p = add_verb(verbs, 'get', get_main, 'Get parameter')
    _common(p)
    p.add_argument('parameter_name', help='Name of the parameter')
    p.add_argument('--hide-type', action='store_true', help='Hide the type information')

    p = add_verb(verbs, 'set', set_main, 'Set parameter')
    _common(p)
    p.add_argument('params_and_values', nargs='+', metavar='name value',
                   help='Parameter name and value pair(s): name value [name value ...]')

    p = add_verb(verbs, 'describe', describe_main, 'Show descriptive information about declared parameters')
    _common(p)
    p.add_argument('parameter_names', nargs='+', help='Names of the parameters')

    p = add_verb(verbs, 'dump', dump_main, 'Show all of the parameters of a node in a YAML file format')
    _common(p)

    p = add_verb(verbs, 'load', load_main, 'Load parameter file for a node')
    _common(p)
    p.add_argument('parameter_file', help='Parameter file')
    p.add_argument('--use-wildcard', action='store_true',
                   help="Load parameters in the '/**' namespace into the node")


class _Params:
    """Parameter services of one node, every call bounded by the service time-out."""

    def __init__(self, cli: CliNode, node_name: str, args) -> None:
        from rclpy.parameter_client import AsyncParameterClient
        self.cli, self.name, self.timeout = cli, node_name, args.service_timeout
        self.client = AsyncParameterClient(cli.node, node_name)
        if not self.client.wait_for_services(timeout_sec=args.timeout):
            raise CliError(f'Wait for service timed out waiting for parameter services for node {node_name}')

    def request(self, service: str, argument):
        """The response of the node's parameter service (an AsyncParameterClient method name)."""
        future = getattr(self.client, service)(list(argument))
        return self.cli.call(future, self.timeout, f"{service} service of node '{self.name}'")

    def list(self, prefixes=()):
        return sorted(self.request('list_parameters', prefixes).result.names)


def _open(cli: CliNode, args) -> _Params:
    name = cli.require_node(args.node_name, timeout=args.timeout, include_hidden=True)
    return _Params(cli, name, args)


def list_main(args) -> int:
    with CliNode(args) as cli:
        if args.node_name:
            targets = [cli.require_node(args.node_name, timeout=args.timeout, include_hidden=True)]
        else:
            targets = cli.node_names(include_hidden=args.include_hidden_nodes)
        regex = re.compile(args.filter) if args.filter else None
        for target in targets:
            try:
                params = _Params(cli, target, args)
                names = params.list(args.param_prefixes)
                if regex:
                    names = [n for n in names if regex.match(n)]
                wanted = args.param_type and names
                types = params.request('get_parameter_types', names).types if wanted else []
            except CliError as exc:
                if args.node_name:
                    raise
                print(exc, file=sys.stderr)
                continue
            if not args.node_name:
                print(f'{target}:')
            for i, name in enumerate(names):
                suffix = f' (type: {TYPE_NAMES.get(types[i], types[i])})' if types else ''
                print(f'  {name}{suffix}')
    return 0


def get_main(args) -> int:
    with CliNode(args) as cli:
        values = _open(cli, args).request('get_parameters', [args.parameter_name]).values
    if not values:
        raise CliError('Parameter not set')
    value = values[0]
    if value.type == 0:
        print('Parameter not set.')
        return 0
    print(format_get(value, args.hide_type))
    return 0


def format_get(value, hide_type: bool = False) -> str:
    """The line `ros2 param get` prints for a ParameterValue, as upstream (arrays as lists)."""
    label, attr = GET_LABELS[value.type]
    shown = getattr(value, attr)
    if hasattr(shown, 'tolist'):
        shown = shown.tolist()
    return str(shown) if hide_type else f'{label} {shown}'


def parameter_from_value(name: str, value, declared_type: int | None = None):
    """rclpy Parameter from a YAML-parsed value; an empty list takes the declared array type."""
    from rclpy.parameter import Parameter
    if isinstance(value, list) and not value and declared_type in (5, 6, 7, 8, 9):
        return Parameter(name, Parameter.Type(declared_type), [])
    if isinstance(value, list) and value and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                 for v in value) and any(isinstance(v, float) for v in value):
        value = [float(v) for v in value]      # [1, 2.5] is a double array
    try:
        return Parameter(name, value=value)
    except TypeError:
        return Parameter(name, value=str(value) if not isinstance(value, list) else repr(value))


def _parse_value(text: str):
    try:
        return load_yaml(text)
    except Exception:       # noqa: BLE001 - not YAML: upstream takes the text as a string
        return text


def set_main(args) -> int:
    pairs = list(zip(args.params_and_values[::2], args.params_and_values[1::2]))
    if len(args.params_and_values) % 2:
        raise CliError('Parameters must be provided as name/value pairs: name value [name value ...]. '
                       f'Got {len(args.params_and_values)} argument(s).')
    with CliNode(args) as cli:
        params = _open(cli, args)
        results = params.request('set_parameters',
                                 [parameter_from_value(n, _parse_value(v)) for n, v in pairs]).results
    for (name, _), result in zip(pairs, results):
        msg = 'Set parameter successful' if result.successful else 'Setting parameter failed'
        if result.reason:
            msg += ': ' + result.reason
        if len(pairs) > 1:
            msg = f'{name}: {msg}'
        print(msg, file=sys.stdout if result.successful else sys.stderr)
    return 0


def describe_main(args) -> int:
    with CliNode(args) as cli:
        descriptors = _open(cli, args).request('describe_parameters', args.parameter_names).descriptors
    for d in descriptors:
        print('Parameter name:', d.name)
        print('  Type:', TYPE_NAMES.get(d.type, d.type))
        if d.description:
            print('  Description:', d.description)
        print('  Constraints:')
        if d.read_only:
            print('    Read only: true')
        if d.dynamic_typing:
            print('    Dynamic typing: true')
        ranges = list(d.floating_point_range) + list(d.integer_range)
        if ranges:
            print('    Min value:', ranges[0].from_value)
            print('    Max value:', ranges[0].to_value)
            if ranges[0].step:
                print('    Step:', ranges[0].step)
        if d.additional_constraints:
            print('    Additional constraints:', d.additional_constraints)
    return 0


def _nest(tree: dict, dotted: str, value) -> None:
    head, dot, rest = dotted.partition('.')
    if dot:
        _nest(tree.setdefault(head, {}), rest, value)
    else:
        tree[dotted] = value


def dump_main(args) -> int:
    from rclpy.parameter import parameter_value_to_python
    with CliNode(args) as cli:
        params = _open(cli, args)
        names = params.list()
        values = params.request('get_parameters', names).values if names else []
    tree: dict = {}
    for name, value in zip(names, values):
        python = parameter_value_to_python(value)
        if not isinstance(python, (bool, int, float, str, type(None))):
            python = list(python)
        _nest(tree, name, python)
    print(dump_yaml({params.name: {'ros__parameters': tree}}))
    return 0


def parameters_for_node(document, node_name: str, use_wildcard: bool, path: str) -> dict:
    """Flat name -> value of node_name's ros__parameters in a parameter file (wildcard first)."""
    if not isinstance(document, dict):
        raise CliError(f'{path}: not a ROS 2 parameter file (expected <node>: {{ros__parameters: ...}})')
    found = {}
    keys = (['/**'] if use_wildcard else []) + [node_name, node_name.lstrip('/')]
    for key in keys:
        entry = document.get(key)
        if entry is None:
            continue
        if not isinstance(entry, dict) or not isinstance(entry.get('ros__parameters'), dict):
            raise CliError(f"{path}: '{key}' has no ros__parameters mapping")
        found.update(flatten(entry['ros__parameters']))
    if not found and not any(k in document for k in keys):
        raise CliError(f'Param file does not contain parameters for {node_name}, '
                       f"only for nodes: {', '.join(map(str, document))}")
    return found


def load_main(args) -> int:
    try:
        with open(args.parameter_file, encoding='utf-8') as stream:
            document = load_yaml(stream.read())
    except OSError as exc:
        raise CliError(f'{args.parameter_file}: {exc.strerror}') from None
    except Exception as exc:       # noqa: BLE001 - a YAML error of any kind
        raise CliError(f'{args.parameter_file}: not valid YAML ({exc})') from None
    with CliNode(args) as cli:
        params = _open(cli, args)
        wanted = parameters_for_node(document, params.name, args.use_wildcard, args.parameter_file)
        names = list(wanted)
        declared = dict(zip(names, params.request('get_parameter_types', names).types)) if names else {}
        parameters = [parameter_from_value(n, v, declared.get(n)) for n, v in wanted.items()]
        results = params.request('set_parameters', parameters).results if parameters else []
    for name, result in zip(names, results):
        msg = f"Set parameter {name} {'successful' if result.successful else 'failed'}"
        if result.reason:
            msg += f': {result.reason}'
        print(msg)
    return 0
