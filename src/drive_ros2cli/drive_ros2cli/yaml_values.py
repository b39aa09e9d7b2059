"""YAML for parameter values: floats stay floats in both directions (``1e-06`` is a float, as
for rcl and YAML 1.2, not PyYAML's YAML 1.1 string; dumped as ``1.0e-06``)."""
from __future__ import annotations

import re

import yaml

_FLOAT_RE = re.compile(r'^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$')


class _Loader(yaml.SafeLoader):
    """SafeLoader that also resolves '1e-06', '2E5' as floats (YAML 1.2 core schema)."""


_Loader.add_implicit_resolver('tag:yaml.org,2002:float', _FLOAT_RE, list('-+0123456789.'))


def load_yaml(text: str):
    return yaml.load(text, Loader=_Loader)


def dump_yaml(data) -> str:
    return yaml.safe_dump(data, default_flow_style=False, sort_keys=False, allow_unicode=True)
