"""Scenario files: a wrong key or value names the file, the key and the reason."""
import textwrap

import pytest

from drive_bringup.scenario import ScenarioError, load_scenario, scenario_dir


def write(tmp_path, text: str):
    path = tmp_path / 'sc.yaml'
    path.write_text(textwrap.dedent(text))
    return path


GOOD = '''
    name: probe
    duration: 0.01
    nodes:
      plant: {parameters: {}}
'''


def test_minimal_scenario_loads_with_node_defaults(tmp_path):
    sc = load_scenario(write(tmp_path, GOOD))
    assert sc.name == 'probe' and sc.duration == 0.01
    assert sc.nodes == ['plant']
    assert sc.node_parameters['plant']  # full validated snapshot of the plant schema


EXAMPLE = ('{package: drive_examples, executable: hysteresis_current_controller, '
           'core: "drive_examples.hysteresis_current_controller:HysteresisCurrentCore"}')


def test_own_controller_entry_gives_its_program_schema_and_events(tmp_path):
    sc = load_scenario(write(tmp_path, GOOD + f'''
      controller: {EXAMPLE}
    events: [{{time: 0.005, node: controller, parameters: {{torque_reference: 0.5}}}}]
    '''))
    assert sc.controller.node_name == 'hysteresis_current_controller'      # default: the executable
    assert sc.node_parameters['controller']['current_band'] == 0.2          # the core's schema
    assert 'current_band' in sc.schema('controller').names()
    assert sc.events[0].node == 'controller'


@pytest.mark.parametrize('text, key, reason', [
    ('name: x\nduration: 0.1\nnodes: {plant: {}}\nbogus: 1\n', 'bogus', 'unknown key'),
    ('name: x\nnodes: {plant: {}}\n', 'duration', 'required key missing'),
    ('name: x\nduration: -1\nnodes: {plant: {}}\n', 'duration', 'must be > 0'),
    ('name: x\nduration: 0.1\nnodes: {dtc_controller: {}}\n', 'nodes.plant', 'required'),
    ('name: x\nduration: 0.1\nnodes: {plant: {}, motor: {}}\n', 'nodes.motor', 'unknown node'),
    ('name: x\nduration: 0.1\nnodes: {plant: {parameters: {no_such_parameter: 1}}}\n',
     'nodes.plant.parameters', 'unknown parameter'),
    ('name: x\nduration: 0.1\nnodes: {plant: {}}\nevents: [{time: 0.2, node: plant, parameters: {}}]\n',
     'events[0].time', 'outside'),
    ('name: x\nduration: 0.1\nnodes: {plant: {}}\nevents: [{time: 0.01, node: dtc_controller, parameters: {a: 1}}]\n',
     'events[0].node', 'not a node of this scenario'),
    ('name: x\nduration: 0.1\nnodes: {plant: {}}\nchecks: [{metric: m, seed: 1.0}]\n',
     'checks[0]', 'seed and tolerance go together'),
    ('name: [x\n', '', 'not valid YAML'),
    ('name: x\nduration: 0.1\nnodes: {plant: {}}\nchecks: [{metric: no_such_metric, max: 1}]\n',
     'checks[0].metric', 'no metric named'),
    ('name: x\nduration: 0.1\nnodes: {plant: {}}\nchecks: [{metric: peak_phase_current_A, seed: 1, tolerance: -1}]\n',
     'checks[0].tolerance', 'must be >= 0'),
    ('name: x\nduration: 0.1\nnodes: {plant: {}}\nchecks: [{metric: peak_phase_current_A, min: 5, max: 1}]\n',
     'checks[0]', 'above max'),
    ('name: x\nduration: 0.1\nnodes: {plant: {}}\nrecord: {enabled: "false"}\n',
     'record.enabled', 'expected true or false'),
    ('name: x\nduration: 0.1\nnodes: {plant: {}}\nrecord: {topics: ["not a topic!!"]}\n',
     'record.topics[0]', 'not a valid ROS topic name'),
    ('name: x\nduration: 0.1\nnodes: {plant: {}}\nrecord: {lockstep: 1}\n',
     'record.lockstep', 'expected true or false'),
    ('name: x\nduration: 0.1\nnodes: {plant: {}}\nrecord: {viewer_period: -0.001}\n',
     'record.viewer_period', 'expected s in [0, 1] or false'),
    ('name: x\nduration: 0.1\nnodes: {plant: {}}\nrecord: {viewer_period: true}\n',
     'record.viewer_period', 'expected s in [0, 1] or false'),
    ('name: x\nduration: 0.1\nnodes: {plant: {}}\nfigures: [no_such_figure]\n',
     'figures[0]', 'unknown figure'),
    ('name: x\nduration: 0.1\nnodes: {plant: {}}\nmetrics: {bogus: {x: 1}}\n',
     'metrics.bogus', 'no metric named'),
    # your own controller (nodes.controller)
    ('name: x\nduration: 0.1\nnodes: {plant: {}, controller: {package: p, core: "m:C"}}\n',
     'nodes.controller.executable', 'required'),
    ('name: x\nduration: 0.1\nnodes: {plant: {}, controller: {package: p, executable: e, core: C}}\n',
     'nodes.controller.core', 'expected module:Class'),
    ('name: x\nduration: 0.1\nnodes: {plant: {}, controller: {package: p, executable: e, '
     'core: "no_such_module:C"}}\n', 'nodes.controller.core', 'No module named'),
    ('name: x\nduration: 0.1\nnodes: {plant: {}, controller: {package: p, executable: e, '
     'core: "drive_common.samples:DriveSample"}}\n', 'nodes.controller.core', 'not a controller core'),
    (f'name: x\nduration: 0.1\nnodes: {{plant: {{}}, dtc_controller: {{}}, controller: {EXAMPLE}}}\n',
     'nodes.controller', 'either dtc_controller or its own'),
    (f'name: x\nduration: 0.1\nnodes: {{plant: {{}}, controller: {EXAMPLE[:-1]}, parameters: {{current_band: -1}}}}}}\n',
     'nodes.controller.parameters', 'current_band'),
    (f'name: x\nduration: 0.1\nnodes: {{plant: {{}}, controller: {EXAMPLE[:-1]}, bogus: 1}}}}\n',
     'nodes.controller.bogus', 'unknown key'),
])
def test_errors_name_file_key_and_reason(tmp_path, text, key, reason):
    path = tmp_path / 'bad.yaml'
    path.write_text(text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    message = str(info.value)
    assert str(path) in message and key in message and reason in message, message


def test_shipped_scenarios_are_valid():
    paths = sorted(scenario_dir().glob('*.yaml'))
    assert paths, 'no scenarios shipped'
    for path in paths:
        sc = load_scenario(path)
        assert sc.name == path.stem, f'{path}: name must equal the file name'


def test_default_recording_is_the_blocks_and_lockstep_topics_only_on_request(tmp_path):
    """No recorder subscription on a per-sample topic by default; record.lockstep
    adds the raw lockstep topics, record.topics replaces the list."""
    from drive_bringup.runner import record_topics
    base = 'name: x\nduration: 0.1\nnodes: {plant: {}, dtc_controller: {}}\n'
    default = record_topics(load_scenario(write(tmp_path, base)))
    assert default == ['/plant/state_block', '/dtc/status_block', '/clock', '/diagnostics',
                       '/parameter_events']
    lockstep = record_topics(load_scenario(write(tmp_path, base + 'record: {lockstep: true}\n')))
    assert lockstep == default + ['/drive/measurement', '/drive/gate_command']
    listed = record_topics(load_scenario(write(tmp_path, base + 'record: {topics: [plant/state]}\n')))
    assert listed == ['/plant/state']
    # viewer topics (derived by the recorder, no subscription): 1 ms by default, a period, or off
    assert load_scenario(write(tmp_path, base)).record_viewer_period == 1e-3
    assert load_scenario(write(tmp_path, base + 'record: {viewer_period: 0}\n')).record_viewer_period == 0.0
    assert load_scenario(write(tmp_path, base + 'record: {viewer_period: false}\n')).record_viewer_period is None
