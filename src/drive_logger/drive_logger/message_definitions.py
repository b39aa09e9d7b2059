"""Message definitions and type hashes of ROS interfaces, as rosbag2 stores them (no rclpy).

A schema is the root ``.msg`` verbatim, then every dependency once, depth-first with sorted
dependencies, each after ``"\\n" + "=" * 80 + "\\nMSG: pkg/Type\\n"`` (docs/architecture.md
"Bags"); the type hash comes from the ``.json`` rosidl installs beside the ``.msg``, under
``share/<pkg>/msg/`` of a prefix on ``AMENT_PREFIX_PATH``.
"""
from __future__ import annotations

import json
import os
import re
import struct
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

DELIMITER = '=' * 80
PRIMITIVE_TYPES = frozenset({
    'bool', 'byte', 'char', 'float32', 'float64', 'int8', 'uint8', 'int16', 'uint16',
    'int32', 'uint32', 'int64', 'uint64', 'string', 'wstring',
})
_ARRAY_OR_BOUND = re.compile(r'(\[[^\]]*\]|<=\d+)')


class DefinitionNotFoundError(LookupError):
    """A message type whose .msg definition is not installed on AMENT_PREFIX_PATH."""


@dataclass(frozen=True)
class TypeDefinition:
    """What a bag needs to know about one message type."""

    name: str          # pkg/msg/Type
    text: str          # ros2msg schema text with the dependent definitions
    type_hash: str     # RIHS01_... ('' when the installed package carries no .json)


def normalize_type_name(type_name: str) -> str:
    """'pkg/Type' or 'pkg/msg/Type' -> 'pkg/msg/Type'; raise ValueError otherwise."""
    parts = type_name.strip().split('/')
    if len(parts) == 2 and all(parts):
        return f'{parts[0]}/msg/{parts[1]}'
    if len(parts) == 3 and all(parts) and parts[1] == 'msg':
        return '/'.join(parts)
    raise ValueError(f'not a message type name: {type_name!r} (expected pkg/msg/Type)')


def _prefixes() -> list[Path]:
    return [Path(p) for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p]


@lru_cache(maxsize=None)
def interface_file(type_name: str, suffix: str = '.msg') -> Path:
    """Path of share/<pkg>/msg/<Type><suffix> in the first prefix that has it."""
    pkg, _, name = normalize_type_name(type_name).split('/')
    for prefix in _prefixes():
        path = prefix / 'share' / pkg / 'msg' / f'{name}{suffix}'
        if path.is_file():
            return path
    raise DefinitionNotFoundError(
        f'no definition share/{pkg}/msg/{name}{suffix} for {type_name!r} on AMENT_PREFIX_PATH '
        '(is the package installed and scripts/env.sh sourced?)')


def dependencies(msg_text: str, package: str) -> list[str]:
    """Sorted 'pkg/Type' names of the non-primitive field types of a .msg text."""
    deps = set()
    for line in msg_text.splitlines():
        line = line.split('#', 1)[0].strip()
        if not line:
            continue
        field_type = _ARRAY_OR_BOUND.sub('', line.split()[0])
        if field_type in PRIMITIVE_TYPES:
            continue
        if field_type == 'Header':
            deps.add('std_msgs/Header')
        elif '/' in field_type:
            pkg, _, name = normalize_type_name(field_type).split('/')
            deps.add(f'{pkg}/{name}')
        else:
            deps.add(f'{package}/{field_type}')
    return sorted(deps)


@lru_cache(maxsize=None)
def message_text(type_name: str) -> str:
    """The installed .msg file of type_name, verbatim."""
    return interface_file(type_name).read_text()


@lru_cache(maxsize=None)
def full_definition(type_name: str) -> str:
    """ros2msg schema text: root definition, then each dependency once, depth-first."""
    seen: set[str] = set()

    def append(name: str) -> str:
        text = message_text(name)
        result = text
        for dep in dependencies(text, name.split('/')[0]):
            if dep not in seen:
                seen.add(dep)
                result += f'\n{DELIMITER}\nMSG: {dep}\n' + append(dep)
        return result

    return append(normalize_type_name(type_name))


@lru_cache(maxsize=None)
def type_hash(type_name: str) -> str:
    """RIHS01 type description hash from the installed .json ('' if there is none)."""
    full = normalize_type_name(type_name)
    try:
        path = interface_file(full, '.json')
    except DefinitionNotFoundError:
        return ''
    for entry in json.loads(path.read_text()).get('type_hashes', []):
        if entry.get('type_name') == full:
            return entry.get('hash_string', '')
    return ''


def type_definition(type_name: str) -> TypeDefinition:
    """Schema text and hash of type_name; DefinitionNotFoundError if not installed."""
    full = normalize_type_name(type_name)
    return TypeDefinition(full, full_definition(full), type_hash(full))


HEADER_FIELD_TYPES = frozenset({'std_msgs/Header', 'std_msgs/msg/Header', 'Header'})
CLOCK_TYPE = 'rosgraph_msgs/msg/Clock'
_CONSTANT = re.compile(r'^\S+\s+[A-Za-z]\w*\s*=')


def first_field_is_header(definition_text: str) -> bool:
    """True if the first field (constants skipped) of a .msg / ros2msg text is a std_msgs/Header."""
    for line in definition_text.splitlines():
        line = line.split('#', 1)[0].strip()
        if line and not _CONSTANT.match(line):
            return line.split()[0] in HEADER_FIELD_TYPES
    return False


PARAMETER_EVENT_TYPE = 'rcl_interfaces/msg/ParameterEvent'
SIM_TIME_LIMIT_NS = 10**18   # 1e9 s (2001-09-09 as a wall time): later stamps are wall times

# How a type's leading builtin_interfaces/Time relates to sim time (sim_stamp_kind).
SAMPLE_STAMP = 'sample'   # always the sim time of its sample
NODE_STAMP = 'node'       # the publishing node's time: sim time from a drive node, else wall time
NO_STAMP = ''             # no sim time in the data


@lru_cache(maxsize=None)
def carries_sim_stamp(type_name: str) -> bool:
    """True if a message of type_name starts with its sample's sim time: a std_msgs/Header (the
    drive graph's messages) or rosgraph_msgs/Clock (node-stamped types: :func:`sim_stamp_kind`)."""
    full = normalize_type_name(type_name)
    return full == CLOCK_TYPE or first_field_is_header(message_text(full))


def sim_stamp_kind(type_name: str) -> str:
    """SAMPLE_STAMP, NODE_STAMP (rcl_interfaces/ParameterEvent: sim time from a drive node, else
    wall time; :func:`is_sim_stamp`) or NO_STAMP for type_name."""
    if carries_sim_stamp(type_name):
        return SAMPLE_STAMP
    return NODE_STAMP if normalize_type_name(type_name) == PARAMETER_EVENT_TYPE else NO_STAMP


def is_sim_stamp(stamp_ns: int) -> bool:
    """A node's stamp that is plausible as sim time: in [0, 1e9 s) (wall clocks read > 1.7e9 s)."""
    return 0 <= stamp_ns < SIM_TIME_LIMIT_NS


def cdr_stamp_ns(data: bytes) -> int:
    """The leading builtin_interfaces/Time of CDR bytes, in ns, without deserializing
    (:func:`carries_sim_stamp`); ValueError for bytes with no room for one."""
    if len(data) < 12 or data[0] != 0 or data[1] not in (0, 1):
        raise ValueError('not a CDR message with a leading time stamp')
    sec, nanosec = struct.unpack_from('<iI' if data[1] == 1 else '>iI', data, 4)
    return sec * 1_000_000_000 + nanosec
