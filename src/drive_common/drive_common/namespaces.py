"""Several drives in one DDS domain, one ROS namespace each; the global topics (``/clock``,
``/diagnostics``, ``/parameter_events``) are remapped into it too (README "Several drives in
one domain")."""
from __future__ import annotations

GLOBAL_TOPICS = ('/clock', '/diagnostics', '/parameter_events')


def normalized(namespace: str | None) -> str:
    """'/NAME' (or '' for none) of 'NAME', '/NAME' or '/NAME/'; ValueError if not a valid name."""
    name = (namespace or '').strip('/')
    if not name:
        return ''
    if not all(part and (part[0].isalpha() or part[0] == '_')
               and all(c.isalnum() or c == '_' for c in part) for part in name.split('/')):
        raise ValueError(f'namespace {namespace!r}: letters, digits and _ only, '
                         'each part starting with a letter or _')
    return '/' + name


def full_name(name: str, namespace: str) -> str:
    """'/ns/name' of a node's name and namespace."""
    return namespace.rstrip('/') + '/' + name


def namespace_remappings(namespace: str | None) -> dict[str, str]:
    """The remap rules (``-r from:=to``) that put a node and its global topics into namespace."""
    ns = normalized(namespace)
    if not ns:
        return {}
    return {'__ns': ns, **{topic: ns + topic for topic in GLOBAL_TOPICS}}


def namespace_arguments(namespace: str | None) -> list[str]:
    """The same rules as ``--ros-args -r ...`` arguments (for a node created in-process)."""
    rules = namespace_remappings(namespace)
    return ['--ros-args', *[a for src, dst in rules.items() for a in ('-r', f'{src}:={dst}')]] \
        if rules else []
