"""Sphinx extension: the node, message and scenario reference, generated from the code at every build.

At ``builder-inited`` it writes Markdown tables under ``docs/reference/_generated/``
(gitignored), which the reference pages ``{include}``:

- one file per node: its parameters from the node's ParameterSchema
  (name, type, default, range, unit, when it may change, description) and its
  topics, services and actions from ``drive_common.topics``;
- ``messages.md``: every ``dtc_msgs`` message, service and action, field by
  field with the definition's comments;
- ``scenarios.md``: every shipped scenario (name, seed reference, duration,
  description) from ``src/drive_bringup/scenarios/*.yaml``.

Run standalone (``python docs/_ext/drive_reference.py OUT_DIR``) to write the
same files without Sphinx. Needs the workspace sourced (the schemas import
the node packages).
"""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
GENERATED = Path(__file__).resolve().parents[1] / 'reference' / '_generated'


def _cell(value) -> str:
    """A value as a Markdown table cell (pipes escaped, no line breaks)."""
    text = ' '.join(str(value).split())
    return text.replace('|', '\\|') if text else ' '


def _table(header: tuple[str, ...], rows) -> str:
    """One Markdown table: the header, its rule, then one line per row (a tuple of cell texts)."""
    lines = ['| ' + ' | '.join(header) + ' |', '|' + '---|' * len(header)]
    lines += ['| ' + ' | '.join(cells) + ' |' for cells in rows]
    return '\n'.join(lines) + '\n'


def _code(value) -> str:
    return f'`{value!r}`' if isinstance(value, str) else f'`{value}`'


def _type_name(default) -> str:
    if isinstance(default, list):
        inner = {float: 'double', int: 'integer', str: 'string', bool: 'boolean'}.get(
            type(default[0]) if default else float, 'double')
        return f'{inner} array'
    return {bool: 'boolean', int: 'integer', float: 'double', str: 'string'}.get(type(default), type(default).__name__)


def _range(spec) -> str:
    parts = []
    if spec.choices:
        parts.append('one of ' + ', '.join(f'`{c}`' for c in spec.choices))
    if spec.min_value is not None or spec.max_value is not None:
        low = '−∞' if spec.min_value is None else f'{spec.min_value:g}'
        high = '∞' if spec.max_value is None else f'{spec.max_value:g}'
        parts.append(f'[{low}, {high}]')
    if spec.length is not None:
        parts.append(f'length {spec.length}')
    return '; '.join(parts) or '—'


def _when(spec) -> str:
    if spec.read_only:
        return 'read-only'
    return 'runtime' if spec.runtime else 'held'


def schema_table(schema) -> str:
    """Markdown table of a drive_common.parameters.ParameterSchema."""
    specs = [(name, schema[name]) for name in schema.names()]
    return _table(('name', 'type', 'default', 'range', 'unit', 'changes', 'description'),
                  ((f'`{name}`', _type_name(spec.default), _cell(_code(spec.default)), _cell(_range(spec)),
                    _cell(spec.unit or '—'), _when(spec), _cell(spec.description)) for name, spec in specs))


def node_interfaces() -> dict[str, dict[str, list[tuple[str, str]]]]:
    """Per node: published and subscribed topics, services and actions (names from drive_common.topics)."""
    from drive_common import topics as t
    from drive_logger.live_view import DEFAULT_TOPICS
    return {
        'plant': {
            'publishes': [(t.DRIVE_MEASUREMENT, 'dtc_msgs/msg/DriveMeasurement'),
                          (t.PFC_MEASUREMENT, 'dtc_msgs/msg/PfcMeasurement'),
                          (t.PLANT_STATE_BLOCK, 'dtc_msgs/msg/PlantStateBlock'),
                          (t.PLANT_STATE, 'dtc_msgs/msg/PlantState'),
                          (t.CLOCK, 'rosgraph_msgs/msg/Clock'),
                          (t.DIAGNOSTICS, 'diagnostic_msgs/msg/DiagnosticArray')],
            'subscribes': [(t.GATE_COMMAND, 'dtc_msgs/msg/GateCommand'),
                           (t.DUTY_COMMAND, 'dtc_msgs/msg/DutyCommand')],
            'services': [(t.RESET_PROTECTION_SERVICE, 'dtc_msgs/srv/ResetProtection')],
            'actions': [(t.RUN_ACTION, 'dtc_msgs/action/Run')],
        },
        'dtc_controller': {
            'publishes': [(t.GATE_COMMAND, 'dtc_msgs/msg/GateCommand'),
                          (t.DTC_STATUS_BLOCK, 'dtc_msgs/msg/DtcStatusBlock'),
                          (t.DTC_STATUS, 'dtc_msgs/msg/DtcStatus')],
            'subscribes': [(t.DRIVE_MEASUREMENT, 'dtc_msgs/msg/DriveMeasurement')],
        },
        'pfc_controller': {
            'publishes': [(t.DUTY_COMMAND, 'dtc_msgs/msg/DutyCommand'),
                          (t.PFC_STATUS_BLOCK, 'dtc_msgs/msg/PfcStatusBlock'),
                          (t.PFC_STATUS, 'dtc_msgs/msg/PfcStatus')],
            'subscribes': [(t.PFC_MEASUREMENT, 'dtc_msgs/msg/PfcMeasurement')],
        },
        'recorder': {
            'subscribes': [(t.PLANT_STATE_BLOCK, 'dtc_msgs/msg/PlantStateBlock'),
                           (t.DTC_STATUS_BLOCK, 'dtc_msgs/msg/DtcStatusBlock'),
                           (t.PFC_STATUS_BLOCK, 'dtc_msgs/msg/PfcStatusBlock'),
                           (t.CLOCK, 'rosgraph_msgs/msg/Clock'),
                           (t.DIAGNOSTICS, 'diagnostic_msgs/msg/DiagnosticArray'),
                           (t.PARAMETER_EVENTS, 'rcl_interfaces/msg/ParameterEvent')],
            'services': [(t.RECORDER_MATCHED_SERVICE, 'dtc_msgs/srv/MatchedPublishers')],
        },
        'replay': {
            'publishes': [('the bag\'s topics (or the per-sample topics with `expand_blocks`)', 'as recorded'),
                          (t.CLOCK, 'rosgraph_msgs/msg/Clock')],
        },
        'live_view': {
            'subscribes': [(name, 'as published') for name in DEFAULT_TOPICS],
        },
        'hysteresis_current_controller': {
            'publishes': [(t.GATE_COMMAND, 'dtc_msgs/msg/GateCommand'),
                          (t.DTC_STATUS_BLOCK, 'dtc_msgs/msg/DtcStatusBlock'),
                          (t.DTC_STATUS, 'dtc_msgs/msg/DtcStatus')],
            'subscribes': [(t.DRIVE_MEASUREMENT, 'dtc_msgs/msg/DriveMeasurement')],
        },
    }


def _interface_table(interfaces: dict[str, list[tuple[str, str]]]) -> str:
    return _table(('kind', 'name', 'type'),
                  ((kind, name if name.startswith('the ') else f'`{name}`',
                    f'`{type_name}`' if '/' in type_name else type_name)
                   for kind in ('publishes', 'subscribes', 'services', 'actions')
                   for name, type_name in interfaces.get(kind, [])))


def node_pages() -> dict[str, tuple[str, str, str]]:
    """node -> (package, executable, Markdown of its parameters and interfaces)."""
    from bldc_plant_sim.parameters import PLANT_SCHEMA
    from drive_examples.hysteresis_current_controller import SCHEMA as EXAMPLE_SCHEMA
    from drive_logger.recorder_node import RECORDER_SCHEMA
    from drive_logger.replay_node import REPLAY_SCHEMA
    from dtc_controller.parameters import DTC_SCHEMA
    from pfc_controller.parameters import PFC_SCHEMA
    from drive_logger.live_view import LIVE_VIEW_SCHEMA
    nodes = {
        'plant': ('bldc_plant_sim', 'plant', schema_table(PLANT_SCHEMA), 'bldc_plant_sim.parameters.PLANT_SCHEMA'),
        'dtc_controller': ('dtc_controller', 'dtc_controller', schema_table(DTC_SCHEMA),
                           'dtc_controller.parameters.DTC_SCHEMA'),
        'pfc_controller': ('pfc_controller', 'pfc_controller', schema_table(PFC_SCHEMA),
                           'pfc_controller.parameters.PFC_SCHEMA'),
        'recorder': ('drive_logger', 'recorder', schema_table(RECORDER_SCHEMA),
                     'drive_logger.recorder_node.RECORDER_SCHEMA'),
        'replay': ('drive_logger', 'replay', schema_table(REPLAY_SCHEMA), 'drive_logger.replay_node.REPLAY_SCHEMA'),
        'live_view': ('drive_logger', 'live_view', schema_table(LIVE_VIEW_SCHEMA),
                      'drive_logger.live_view.LIVE_VIEW_SCHEMA'),
        'hysteresis_current_controller': ('drive_examples', 'hysteresis_current_controller',
                                          schema_table(EXAMPLE_SCHEMA),
                                          'drive_examples.hysteresis_current_controller.SCHEMA'),
    }
    interfaces = node_interfaces()
    pages = {}
    for node, (package, executable, table, source) in nodes.items():
        text = (f'`ros2 run {package} {executable}`; parameters from `{source}`.\n\n'
                f'**Parameters** (changes: *runtime* = any time, acts at the next sample; '
                f'*held* = only while the plant holds its time; *read-only* = set at start).\n\n'
                f'{table}\n**Topics, services and actions** (names relative: a namespace moves them).\n\n'
                f'{_interface_table(interfaces[node])}')
        pages[node] = (package, executable, text)
    return pages


def _interface_fields(path: Path) -> str:
    """Field table of one .msg (or one section of .srv/.action): type, name, default/value, comment."""
    rows, comments = [], []
    for raw in path.read_text().splitlines() if isinstance(path, Path) else path:
        text, _, comment = raw.partition('#')
        text, comment = text.strip(), comment.strip()
        if not text:
            if comment:
                comments.append(comment)
            continue
        parts = text.split(None, 2)
        type_name, name = parts[0], parts[1]
        value = ''
        if '=' in name:
            name, value = name.split('=', 1)
        elif len(parts) > 2:
            value = parts[2]
        if value.startswith('='):
            value = value[1:].strip()
        rows.append((f'`{_cell(type_name)}`', f'`{name.strip()}`', _cell(value.strip()) if value else ' ',
                     _cell(comment)))
    return _table(('type', 'name', 'value', 'comment'), rows), ' '.join(comments)


def messages_page() -> str:
    """Markdown of every dtc_msgs interface, from src/dtc_msgs/{msg,srv,action}."""
    out = []
    base = ROOT / 'src/dtc_msgs'
    for kind in ('msg', 'srv', 'action'):
        for path in sorted((base / kind).glob(f'*.{kind}')):
            out.append(f'## `dtc_msgs/{kind}/{path.stem}`\n')
            sections = path.read_text().split('\n---\n')
            names = {'msg': ['fields'], 'srv': ['request', 'response'],
                     'action': ['goal', 'result', 'feedback']}[kind]
            for title, section in zip(names, sections):
                table, prose = _interface_fields(section.splitlines())
                if prose:
                    out.append(prose + '\n')
                if len(sections) > 1:
                    out.append(f'*{title}*\n')
                out.append(table)
    return '\n'.join(out)


def scenarios_page() -> str:
    """Markdown table of every shipped scenario (name, seed reference, duration, description)."""
    from drive_bringup.scenario import load_scenario, scenario_dir
    shipped = [load_scenario(path) for path in sorted(scenario_dir().glob('*.yaml'))]
    return _table(('scenario', 'seed reference', 'duration (s sim)', 'checks', 'description'),
                  ((f'`{s.name}`', _cell(s.seed_reference or '—'), f'{s.duration:g}', str(len(s.checks)),
                    _cell(s.description)) for s in shipped))


def write_all(out: Path = GENERATED) -> list[Path]:
    """Write every generated reference file under out; return their paths."""
    out.mkdir(parents=True, exist_ok=True)
    written = []

    def put(name: str, text: str) -> None:
        path = out / name
        if not path.exists() or path.read_text() != text:   # unchanged files keep Sphinx's cache valid
            path.write_text(text)
        written.append(path)

    for node, (_, _, text) in node_pages().items():
        put(f'node_{node}.md', text)
    put('messages.md', messages_page())
    put('scenarios.md', scenarios_page())
    return written


def _on_builder_inited(app) -> None:
    write_all()


def setup(app):
    app.connect('builder-inited', _on_builder_inited)
    return {'version': '1', 'parallel_read_safe': True, 'parallel_write_safe': True}


if __name__ == '__main__':
    for p in write_all(Path(sys.argv[1]) if len(sys.argv) > 1 else GENERATED):
        print(p)
