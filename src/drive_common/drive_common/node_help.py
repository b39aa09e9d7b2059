"""``--help`` of a node executable (before ``--ros-args``): what the node is and its parameters,
from its schema; prints and exits 0 without starting anything (no rclpy)."""
from __future__ import annotations

import inspect
import os
import sys
from typing import Callable, Sequence

from drive_common.parameters import ParameterSchema, ParameterSpec

HELP_FLAGS = ('-h', '--help')


def wants_help(argv: Sequence[str]) -> bool:
    """True if -h/--help comes before ``--ros-args`` (after it, rcl owns the words)."""
    words = list(argv)     # argv[0] (the program) is never a flag
    if '--ros-args' in words:
        words = words[:words.index('--ros-args')]
    return any(word in HELP_FLAGS for word in words)


def summary_of(obj: object) -> str:
    """First paragraph of obj's module docstring (its own docstring when the module has none)."""
    module = sys.modules.get(getattr(obj, '__module__', '') or '')
    text = inspect.getdoc(module) if module is not None else None
    text = text or inspect.getdoc(obj) or ''
    return text.strip().split('\n\n')[0].strip()


def schema_of(factory: Callable) -> ParameterSchema | None:
    """The node's ParameterSchema: factory.SCHEMA, else the one its module defines or imports."""
    found = getattr(factory, 'SCHEMA', None)
    if isinstance(found, ParameterSchema):
        return found
    module = sys.modules.get(getattr(factory, '__module__', '') or '')
    candidates = [value for name, value in vars(module).items()
                  if name.endswith('SCHEMA') and isinstance(value, ParameterSchema)] if module else []
    return candidates[0] if candidates else None


def _spec_line(spec: ParameterSpec) -> str:
    kind = spec.value_type.__name__
    if spec.value_type is list:
        kind = f'{type(spec.default[0]).__name__ if spec.default else "float"}[]'
    default = repr(spec.default)
    if spec.unit:
        default += f' {spec.unit}'
    extra = spec.limits()
    if spec.read_only:
        extra.append('read-only')
    elif not spec.runtime:
        extra.append('only while held')
    tail = f' ({"; ".join(extra)})' if extra else ''
    return f'  {spec.name} ({kind}, default {default}): {spec.description}{tail}'


def node_usage(package: str, executable: str, summary: str,
               schema: ParameterSchema | None) -> str:
    """The help text of a node executable."""
    lines = [f'usage: ros2 run {package} {executable} [-h] '
             '[--ros-args [-p NAME:=VALUE]... [--params-file FILE] [-r __ns:=/NS] [-r __node:=NAME]]',
             '']
    if summary:
        lines += [summary, '']
    if schema is not None and schema.specs:
        lines.append('parameters (--ros-args -p NAME:=VALUE; SI units):')
        lines += [_spec_line(spec) for spec in schema.specs]
    else:
        lines.append('parameters: none of its own')
    lines += ['', 'examples:',
              f'  ros2 run {package} {executable} --ros-args -r __ns:=/drive1',
              f'  ros2 run {package} {executable} --ros-args --params-file params.yaml',
              'SIGINT/SIGTERM end the node with exit 0; a node that cannot start exits 2 with one line.']
    return '\n'.join(lines)


def print_node_help(about: Callable | type) -> int:
    """Print the help of a node described by about (a node class or factory, or a class
    whose module and ``SCHEMA`` describe it); return 0."""
    package = (getattr(about, '__module__', '') or 'node').split('.')[0]
    executable = os.path.basename(sys.argv[0]) or package
    print(node_usage(package, executable, summary_of(about), schema_of(about)))
    return 0
