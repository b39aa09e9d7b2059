"""``ros2 interface list|show``: installed interfaces (ament index) and their definitions."""
from __future__ import annotations

import re

from drive_ros2cli import messages
from drive_ros2cli.errors import CliError
from drive_ros2cli.verbs import add_verb

DESCRIPTION = 'Show information about ROS interfaces'
_FIELD = re.compile(r'^(\s*)([A-Za-z][\w/]*)(\[[^\]]*\]|<=\d+)?(\s+\S.*)$')


def add_verbs(verbs) -> None:
    p = add_verb(verbs, 'list', list_main, 'List all interface types available')
    p.add_argument('-m', '--only-msgs', action='store_true', help='Print out only the message types')
    p.add_argument('-s', '--only-srvs', action='store_true', help='Print out only the service types')
    p.add_argument('-a', '--only-actions', action='store_true', help='Print out only the action types')

    p = add_verb(verbs, 'show', show_main, 'Output the interface definition')
    p.add_argument('type', help="Show an interface definition (e.g. 'example_interfaces/msg/String')")
    p.add_argument('--all-comments', action='store_true', help='Show all comments, including for nested interface definitions')
    p.add_argument('--no-comments', action='store_true', help='Show no comments or whitespace')


def all_interfaces() -> dict[str, list[str]]:
    """kind ('msg', 'srv', 'action') -> sorted 'pkg/kind/Type' from the rosidl_interfaces index."""
    from ament_index_python.resources import get_resource, get_resources
    found: dict[str, set[str]] = {k: set() for k in messages.KINDS}
    for package in get_resources('rosidl_interfaces'):
        content, _ = get_resource('rosidl_interfaces', package)
        for line in content.splitlines():
            kind, _, file = line.strip().partition('/')
            stem, _, suffix = file.rpartition('.')
            if kind in found and (suffix == kind or suffix == 'idl' and stem):
                found[kind].add(f'{package}/{kind}/{stem}')
    return {k: sorted(v) for k, v in found.items()}


def list_main(args) -> int:
    found = all_interfaces()
    only = {'msg': args.only_msgs, 'srv': args.only_srvs, 'action': args.only_actions}
    for kind, title in (('msg', 'Messages'), ('srv', 'Services'), ('action', 'Actions')):
        if only[kind] or not any(only.values()):
            print(f'{title}:')
            for name in found[kind]:
                print(f'    {name}')
    return 0


def _strip_comments(text: str) -> list[str]:
    lines = []
    for line in text.splitlines():
        if line.strip() == '---':
            lines.append('---')
            continue
        code = line.split('#', 1)[0].rstrip()
        if code.strip():
            lines.append(code)
    return lines


def _nested_type(field_type: str, package: str) -> str | None:
    if field_type in messages.PRIMITIVES:
        return None
    if field_type == 'Header':
        return 'std_msgs/msg/Header'
    parts = field_type.split('/')
    if len(parts) == 1:
        return f'{package}/msg/{parts[0]}'
    return f'{parts[0]}/msg/{parts[-1]}'


def _expand(text: str, package: str, indent: str, comments: bool, nested_comments: bool) -> list[str]:
    out = []
    for line in (text.splitlines() if comments else _strip_comments(text)):
        out.append(indent + line)
        match = _FIELD.match(line.split('#', 1)[0]) if line.strip() and line.strip() != '---' else None
        if not match or '=' in match.group(4):
            continue                          # not a field, or a constant
        nested = _nested_type(match.group(2), package)
        if nested:
            out.extend(_expand(messages.interface_text(nested), nested.split('/')[0], indent + '\t',
                               nested_comments, nested_comments))
    return out


def show_main(args) -> int:
    if len(args.type.split('/')) != 3:
        raise CliError(f"Invalid name '{args.type}'. Expected three parts separated by '/'")
    text = messages.interface_text(args.type)
    lines = _expand(text, args.type.split('/')[0], '', not args.no_comments,
                    args.all_comments and not args.no_comments)
    print('\n'.join(lines))
    return 0
