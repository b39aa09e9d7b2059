"""The shipped viewer layouts parse, and every topic/field path they plot exists in the messages.

Foxglove paths: ``/topic.field`` or ``/topic.field[i]``; PlotJuggler curves:
``/topic/field`` or ``/topic/field[i]`` (its ROS 2 parser's names). A path
naming a topic the bag does not have, a field its message does not have or
an index past a fixed array fails here, not silently in the viewer.
"""
import json
import re
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import pytest

from drive_logger.block_topics import BLOCK_TOPICS
from drive_logger.ros_types import message_class
from drive_logger.sample_topics import ALL_PARTS, SampleTopics

LAYOUTS = Path(__file__).resolve().parents[1] / 'layouts'
FIELD = re.compile(r'^(?P<field>[a-z_0-9]+)(\[(?P<index>\d+)\])?$')


def _topic_types() -> dict[str, str]:
    topics = {t: v[0] for t, v in SampleTopics(parts=ALL_PARTS).topics_for(BLOCK_TOPICS).items()}
    topics['/diagnostics'] = 'diagnostic_msgs/msg/DiagnosticArray'
    return topics


def check_path(topic: str, field: str) -> None:
    """AssertionError unless topic is a viewer topic whose message has field (index within its array)."""
    types = _topic_types()
    assert topic in types, f'{topic}: not a topic of the bag'
    match = FIELD.match(field)
    assert match, f'{topic} {field!r}: not a field path'
    fields = message_class(types[topic]).get_fields_and_field_types()
    name, index = match['field'], match['index']
    assert name in fields, f'{topic}: {types[topic]} has no field {name!r}'
    kind = fields[name]
    if index is not None:
        width = re.search(r'\[(\d+)\]$', kind)
        assert width and int(index) < int(width[1]), f'{topic}.{field}: {kind} has no element {index}'
    else:
        assert not kind.endswith(']'), f'{topic}.{field}: {kind} is an array, plot one element'


def foxglove_paths(layout: dict) -> list[str]:
    paths = []
    for config in layout['configById'].values():
        paths += [p['value'] for p in config.get('paths', [])]
        if 'xAxisPath' in config:
            paths.append(config['xAxisPath']['value'])
    return paths


@pytest.mark.parametrize('name', ['dtc_bag.json', 'dtc_live.json'])
def test_foxglove_layouts_plot_existing_fields(name):
    layout = json.loads((LAYOUTS / name).read_text())
    paths = foxglove_paths(layout)
    assert paths
    for path in paths:
        topic, field = path.split('.', 1)
        check_path(topic, field)
    panels = set(layout['configById'])
    assert panels == set(re.findall(r'"([A-Za-z]+![a-z_]+)"', json.dumps(layout['layout'])))
    for config in layout['configById'].values():
        if 'topicToRender' in config:
            assert config['topicToRender'] in _topic_types()


def test_bag_layout_has_the_panels_people_look_at():
    paths = set(foxglove_paths(json.loads((LAYOUTS / 'dtc_bag.json').read_text())))
    assert {'/plant/state.mechanical_speed', '/plant/state.electromagnetic_torque', '/dtc/status.torque_estimate',
            '/plant/state.phase_current[0]', '/dtc/status.flux_alpha', '/dtc/status.flux_beta',
            '/plant/state.dc_link_voltage', '/pfc/status.current_reference', '/plant/state.safe_state'} <= paths


def test_plotjuggler_layout_plots_existing_fields():
    root = ElementTree.parse(LAYOUTS / 'dtc_bag.xml').getroot()
    names = []
    for curve in root.iter('curve'):
        names += [curve.get(key) for key in ('curve_x', 'curve_y') if curve.get(key)] or [curve.get('name')]
    assert len(names) > 10
    for name in names:
        topic, field = name.rsplit('/', 1)
        check_path(topic, field)


def test_a_wrong_path_is_caught():
    with pytest.raises(AssertionError, match='no field'):
        check_path('/plant/state', 'speed')
    with pytest.raises(AssertionError, match='no element 3'):
        check_path('/plant/state', 'phase_current[3]')
    with pytest.raises(AssertionError, match='not a topic'):
        check_path('/plant/status', 'step')
