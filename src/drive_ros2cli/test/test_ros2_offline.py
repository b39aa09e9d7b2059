"""The embedded `ros2`: usage errors, and the verbs that read the install, not the graph.

- an unknown command or verb, a missing or wrong argument: usage on stderr, exit 2;
- `interface list|show`, `pkg list|executables`, `run` against the installed packages;
- the parameter YAML keeps floats floats (1e-06) and arrays lists both ways;
- a streaming verb started in a script's background still ends on SIGINT.
"""
import os
import shutil
import signal
import subprocess

import pytest
import yaml

from drive_ros2cli.verbs.param import parameter_from_value
from drive_ros2cli.yaml_values import dump_yaml, load_yaml


@pytest.mark.parametrize('args, message', [
    (('frobnicate',), "invalid choice: 'frobnicate'"),
    (('topic', 'frobnicate'), "invalid choice: 'frobnicate'"),
    (('topic', 'echo'), 'the following arguments are required: topic_name'),
    (('param', 'get', '/plant'), 'the following arguments are required: parameter_name'),
    (('topic', 'pub', '--rate', 'fast', '/x', 'std_msgs/msg/String'), "invalid float value: 'fast'"),
    (('node', 'list', '--no-such-option'), 'unrecognized arguments: --no-such-option'),
    (('bag', 'play'), 'the following arguments are required: bag_path'),
])
def test_wrong_usage_prints_usage_and_exits_2(ros2_offline, args, message):
    result = ros2_offline(*args)
    assert result.code == 2
    assert result.err.startswith('usage: ros2') and message in result.err
    assert 'Traceback' not in result.err


def test_help_and_bare_command_print_usage(ros2_offline):
    assert 'usage: ros2 topic' in ros2_offline.ok('topic')
    top = ros2_offline.ok('--help')
    for command in ('action', 'bag', 'interface', 'node', 'param', 'pkg', 'run', 'service', 'topic'):
        assert command in top


def test_interface_list_and_show(ros2_offline):
    listed = ros2_offline.ok('interface', 'list').splitlines()
    sections = [l for l in listed if not l.startswith('    ')]
    assert sections == ['Messages:', 'Services:', 'Actions:']
    assert '    dtc_msgs/msg/GateCommand' in listed and '    dtc_msgs/srv/ResetProtection' in listed
    assert listed.index('    dtc_msgs/action/Run') > listed.index('Actions:')
    assert ros2_offline.ok('interface', 'list', '-a').splitlines()[0] == 'Actions:'

    shown = ros2_offline.ok('interface', 'show', 'dtc_msgs/action/Run')
    assert 'float64 target_time' in shown and shown.count('---') == 2
    duty = ros2_offline.ok('interface', 'show', 'dtc_msgs/msg/DutyCommand', '--no-comments').splitlines()
    assert duty[:4] == ['std_msgs/Header header', '\tbuiltin_interfaces/Time stamp', '\t\tint32 sec',
                        '\t\tuint32 nanosec']
    assert 'float64 duty' in duty and not any('#' in line for line in duty)
    unknown = ros2_offline('interface', 'show', 'dtc_msgs/msg/NoSuchType')
    assert unknown.code == 1 and 'NoSuchType' in unknown.err


def test_pkg_and_run(ros2_offline):
    packages = ros2_offline.ok('pkg', 'list').splitlines()
    assert {'dtc_msgs', 'drive_logger', 'bldc_plant_sim', 'rclpy'} <= set(packages)
    assert packages == sorted(packages)
    executables = ros2_offline.ok('pkg', 'executables', 'drive_logger').splitlines()
    assert {'drive_logger recorder', 'drive_logger replay'} <= set(executables)
    assert ros2_offline('pkg', 'executables', 'no_such_package').code == 1

    ran = ros2_offline('run', 'drive_analysis', 'analyze', '--help')
    assert ran.code == 0 and 'usage:' in ran.out
    missing = ros2_offline('run', 'no_such_package', 'x')
    assert missing.code == 1 and missing.err.strip() == "Package 'no_such_package' not found"
    assert ros2_offline('run', 'drive_logger', 'no_such_executable').err.strip() == 'No executable found'


def test_parameter_yaml_keeps_floats_and_arrays():
    params = {'front_end': {'max_step': 1e-06, 'filter': {'inductance': 1e-05}},
              'sensors': {'current_offset': [0.1, 0.0, -1e-06]}, 'motor': {'pole_pairs': 2, 'file': 'x'}}
    text = dump_yaml({'/plant': {'ros__parameters': params}})
    assert yaml.safe_load(text)['/plant']['ros__parameters'] == params       # YAML 1.1 readers too
    assert load_yaml(text)['/plant']['ros__parameters'] == params
    # what users type: exponent without a dot is a float, not a string
    assert load_yaml('1e-06') == 1e-06 and load_yaml('-2E5') == -200000.0 and load_yaml('e5') == 'e5'
    assert parameter_from_value('x', load_yaml('[1, 2.5]')).value == [1.0, 2.5]
    assert parameter_from_value('x', [], declared_type=8).type_.name == 'DOUBLE_ARRAY'


@pytest.mark.parametrize('field, ptype, value, line', [
    ('bool_value', 1, True, 'Boolean value is: True'),
    ('integer_value', 2, 7, 'Integer value is: 7'),
    ('double_value', 3, 0.25, 'Double value is: 0.25'),
    ('string_value', 4, 'ozturk_bldc', 'String value is: ozturk_bldc'),
    ('byte_array_value', 5, [b'\x01', b'\xff'], "Byte values are: [b'\\x01', b'\\xff']"),
    ('bool_array_value', 6, [True, False], 'Boolean values are: [True, False]'),
    ('integer_array_value', 7, [1, -2, 3], 'Integer values are: [1, -2, 3]'),
    ('double_array_value', 8, [0.1, 0.0, 0.0], 'Double values are: [0.1, 0.0, 0.0]'),
    ('string_array_value', 9, ['a', 'b c'], "String values are: ['a', 'b c']"),
])
def test_param_get_prints_every_type_as_upstream(field, ptype, value, line):
    """Upstream ros2param get: label and the value as a Python list, never array('d', ...)."""
    from rcl_interfaces.msg import ParameterValue

    from drive_ros2cli.verbs.param import format_get
    msg = ParameterValue(type=ptype, **{field: value})
    assert format_get(msg) == line
    assert format_get(msg, hide_type=True) == line.split(': ', 1)[1]


def test_pkg_create_writes_upstream_ament_python_layout(ros2_offline, tmp_path):
    """`ros2 pkg create --build-type ament_python --node-name N NAME`: upstream's files and output lines."""
    out = ros2_offline.ok('pkg', 'create', '--build-type', 'ament_python', '--node-name', 'talker',
                          '--dependencies', 'rclpy', 'std_msgs', '--maintainer-email', 'me@example.org',
                          '--destination-directory', str(tmp_path), 'my_pkg')
    lines = out.splitlines()
    assert lines[0] == 'going to create a new package'
    assert 'package name: my_pkg' in lines and 'build type: ament_python' in lines
    assert "dependencies: ['rclpy', 'std_msgs']" in lines and 'node_name: talker' in lines
    assert 'creating ./my_pkg/package.xml' in lines and 'creating ./my_pkg/my_pkg/talker.py' in lines
    root = tmp_path / 'my_pkg'
    files = sorted(str(p.relative_to(root)) for p in root.rglob('*') if p.is_file())
    assert files == ['my_pkg/__init__.py', 'my_pkg/talker.py', 'package.xml', 'resource/my_pkg',
                     'setup.cfg', 'setup.py']
    assert (root / 'test').is_dir()
    xml = (root / 'package.xml').read_text()
    assert '<package format="3">' in xml and '<depend>std_msgs</depend>' in xml
    assert '<maintainer email="me@example.org">' in xml and '<build_type>ament_python</build_type>' in xml
    assert "'talker = my_pkg.talker:main'" in (root / 'setup.py').read_text()
    assert (root / 'setup.cfg').read_text() == ('[develop]\nscript_dir=$base/lib/my_pkg\n'
                                                '[install]\ninstall_scripts=$base/lib/my_pkg\n')
    again = ros2_offline('pkg', 'create', '--build-type', 'ament_python',
                         '--destination-directory', str(tmp_path), 'my_pkg')
    assert again.code == 1 and 'The directory already exists' in again.err


def test_pkg_create_controller_template_and_bad_input(ros2_offline, tmp_path):
    ros2_offline.ok('pkg', 'create', '--build-type', 'ament_python', '--template', 'drive_controller',
                    '--destination-directory', str(tmp_path), 'my_ctrl')
    root = tmp_path / 'my_ctrl'
    assert 'run_controller(Core, \'my_ctrl\', args)' in (root / 'my_ctrl' / 'my_ctrl.py').read_text()
    assert (root / 'test' / 'test_my_ctrl.py').is_file()
    assert '<depend>drive_common</depend>' in (root / 'package.xml').read_text()
    for args, message in [(('--build-type', 'ament_python', 'Bad-Name'), "invalid package name 'Bad-Name'"),
                          (('--template', 'drive_controller', 'x'), 'needs --build-type ament_python'),
                          (('--build-type', 'ament_python', 'test'), "can't be named 'test'")]:
        result = ros2_offline('pkg', 'create', '--destination-directory', str(tmp_path), *args)
        assert result.code == 1 and message in result.err and 'Traceback' not in result.err


def test_a_verb_started_in_a_scripts_background_ends_on_sigint(ros2_offline):
    """A non-interactive shell starts a background job with SIGINT ignored: Ctrl-C's signal
    still ends the verb, with upstream's code 2."""
    script = (f'"{shutil.which("ros2")}" topic pub -r 5 /background std_msgs/msg/String & echo "pid $!"; '
              'wait $!; echo "exit $?"')
    shell = subprocess.Popen(['bash', '-c', script], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                             text=True, env=ros2_offline.env)
    lines = []
    try:
        for line in shell.stdout:          # until the loop runs (or EOF: the verb failed)
            lines.append(line)
            if line.startswith('pid '):
                pid = int(line.split()[1])
            if 'publisher: beginning loop' in line:
                os.kill(pid, signal.SIGINT)
                break
        try:
            lines.append(shell.communicate(timeout=60)[0])
        except subprocess.TimeoutExpired:
            pytest.fail(f'still publishing 60 s after SIGINT:\n{"".join(lines)}')
    finally:
        if shell.poll() is None:
            os.kill(pid, signal.SIGKILL)
            shell.kill()
    assert 'exit 2' in ''.join(lines), ''.join(lines)
