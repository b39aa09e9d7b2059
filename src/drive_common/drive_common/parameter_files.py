"""ROS 2 parameter files (``--params-file``), read as rcl reads them: checked up front with
one-line errors, and one node's values for the scenario runner (nested keys become dotted names).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

WILDCARDS = ('/**', '**')


class ParameterFileError(ValueError):
    """The file cannot be read or is not a ROS 2 parameter file; the message names it."""


def flatten(mapping: dict, prefix: str = '') -> dict[str, Any]:
    """{dotted name: value} of nested mappings (``motor: {file: x}`` -> ``motor.file``)."""
    out = {}
    for key, value in mapping.items():
        name = f'{prefix}{key}'
        if isinstance(value, dict):
            out.update(flatten(value, name + '.'))
        else:
            out[name] = value
    return out


def read_params_file(path: str | Path) -> dict[str, dict[str, Any]]:
    """{node key as written: {dotted parameter name: value}}; ParameterFileError otherwise."""
    import yaml
    try:
        data = yaml.safe_load(Path(path).read_text())
    except OSError as exc:
        raise ParameterFileError(f'params file {path}: {exc.strerror or exc}') from None
    except yaml.YAMLError as exc:
        where = getattr(exc, 'problem_mark', None)
        line = f' (line {where.line + 1})' if where else ''
        raise ParameterFileError(f'params file {path}: not valid YAML{line}') from None
    if not isinstance(data, dict):
        raise ParameterFileError(f'params file {path}: expected node_name: {{ros__parameters: ...}}')
    sections = {}
    for node, body in data.items():
        if not isinstance(body, dict) or not isinstance(body.get('ros__parameters'), dict):
            raise ParameterFileError(f'params file {path}: {node}: expected a ros__parameters mapping')
        sections[str(node)] = flatten(body['ros__parameters'])
    return sections


def parameters_for(node_name: str, sections: dict[str, dict[str, Any]],
                   known=None) -> dict[str, Any]:
    """The values a node named node_name takes: the wildcard section (only the names in
    ``known``, when given, as rcl ignores undeclared ones), then its own section."""
    values = {k: v for key in WILDCARDS for k, v in sections.get(key, {}).items()
              if known is None or k in known}
    for key, section in sections.items():
        if key not in WILDCARDS and node_of(key) == node_name.lstrip('/'):
            values.update(section)
    return values


def node_of(key: str) -> str:
    """The node name of a section key (``/ns/plant`` -> ``plant``)."""
    return key.lstrip('/').split('/')[-1]


def params_files_in(args) -> list[str]:
    """The files of every ``--params-file F`` in a command line."""
    args = list(args or [])
    return [args[i + 1] for i, arg in enumerate(args[:-1]) if arg == '--params-file']
