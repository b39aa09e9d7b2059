"""Interface types and message <-> YAML conversion (rosidl_runtime_py's job, not in the wheels)."""
from __future__ import annotations

import importlib
import os
import sys
from pathlib import Path

import yaml

from drive_ros2cli.errors import CliError
from drive_ros2cli.yaml_values import load_yaml

KINDS = ('msg', 'srv', 'action')
_FLOATS = {'float', 'double'}
_INTS = {'int8', 'uint8', 'int16', 'uint16', 'int32', 'uint32', 'int64', 'uint64', 'byte', 'octet'}
PRIMITIVES = _FLOATS | _INTS | {'boolean', 'bool', 'char', 'string', 'wstring', 'float32', 'float64',
                                'time', 'duration'}


def split_type(type_name: str, default_kind: str = 'msg') -> tuple[str, str, str]:
    """'pkg/kind/Type' or 'pkg/Type' -> (pkg, kind, Type); CliError if malformed."""
    parts = type_name.strip().split('/')
    if len(parts) == 2 and all(parts):
        return parts[0], default_kind, parts[1]
    if len(parts) == 3 and all(parts) and parts[1] in KINDS:
        return parts[0], parts[1], parts[2]
    raise CliError(f"The passed type '{type_name}' is invalid")


def interface_class(type_name: str, default_kind: str = 'msg'):
    """The class of ``pkg/kind/Type`` (or ``pkg/Type`` of default_kind)."""
    pkg, kind, name = split_type(type_name, default_kind)
    try:
        return getattr(importlib.import_module(f'{pkg}.{kind}'), name)
    except (ImportError, AttributeError):
        raise CliError(f"The passed {dict(msg='message', srv='service', action='action')[kind]} "
                       f"type '{type_name}' is invalid") from None


def is_message(value) -> bool:
    return hasattr(type(value), 'get_fields_and_field_types')


def to_plain(value):
    """Message -> dict in field order; arrays -> lists of Python scalars; bytes -> str."""
    if is_message(value):
        return {name: to_plain(getattr(value, name)) for name in value.get_fields_and_field_types()}
    if isinstance(value, (bytes, bytearray)):
        return ''.join(chr(c) for c in value)
    if isinstance(value, (list, tuple)) or hasattr(value, 'tolist') or type(value).__name__ == 'array':
        items = value.tolist() if hasattr(value, 'tolist') else list(value)
        return [to_plain(v) for v in items]
    return value


def to_yaml(value) -> str:
    """YAML text of a message (or of one field's value) as upstream's echo prints it."""
    plain = to_plain(value)
    text = yaml.safe_dump(plain, allow_unicode=True, width=sys.maxsize,
                          default_flow_style=False, sort_keys=False)
    if not isinstance(plain, (dict, list)) and text.endswith('\n...\n'):
        text = text[:-4]                  # a bare scalar: no explicit document end
    return text


def _convert(field_type: str, value, where: str):
    base = field_type.split('<')[0].split('[')[0]
    is_sequence = field_type.startswith('sequence<') or field_type.endswith(']')
    if is_sequence:
        if base == 'sequence':
            base = field_type[len('sequence<'):].split(',')[0].rstrip('>')
        if not isinstance(value, (list, tuple)):
            raise CliError(f"Failed to populate field '{where}': expected a list, got {value!r}")
        return [_convert(base, v, where) for v in value]
    try:
        if base in _FLOATS:
            return float(value)
        if base in _INTS:
            if isinstance(value, bool) or float(value) != int(value):
                raise ValueError('not an integer')
            return int(value)
        if base == 'boolean':
            if not isinstance(value, bool):
                raise ValueError('not a boolean (true/false)')
            return value
        if base in ('string', 'wstring'):
            return str(value)
    except (TypeError, ValueError) as exc:
        raise CliError(f"Failed to populate field '{where}': {value!r} is {exc}") from None
    return value


def fill(msg, values, prefix: str = ''):
    """Set msg's fields from a mapping (YAML-parsed), converted to their types; returns msg."""
    if values is None:
        return msg
    if not isinstance(values, dict):
        raise CliError(f"Failed to populate field{' ' + repr(prefix) if prefix else ''}: "
                       f'expected a mapping of field names, got {values!r}')
    fields = msg.get_fields_and_field_types()
    for name, value in values.items():
        where = f'{prefix}.{name}' if prefix else str(name)
        if name not in fields:
            raise CliError(f"Failed to populate field '{where}': {type(msg).__name__} "
                           f"has no field '{name}' (fields: {', '.join(fields)})")
        current = getattr(msg, name)
        if is_message(current):
            fill(current, value, where)
            continue
        try:
            setattr(msg, name, _convert(fields[name], value, where))
        except (AssertionError, TypeError, ValueError) as exc:
            raise CliError(f"Failed to populate field '{where}': {exc}") from None
    return msg


def parse_values(text: str, where: str = 'values'):
    """The YAML of a message given on the command line ('{a: 1}' or 'a: 1')."""
    try:
        return load_yaml(text) if text else {}
    except yaml.YAMLError as exc:
        raise CliError(f'the passed value needs to be a dictionary in YAML format: {exc}') from None


def interface_text(type_name: str) -> str:
    """The installed definition file of an interface, verbatim."""
    pkg, kind, name = split_type(type_name)
    for prefix in filter(None, os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep)):
        path = Path(prefix, 'share', pkg, kind, f'{name}.{kind}')
        if path.is_file():
            return path.read_text()
    raise CliError(f"Unknown interface '{type_name}'" if len(type_name.split('/')) == 3
                   else f"Invalid name '{type_name}'. Expected three parts separated by '/'")
