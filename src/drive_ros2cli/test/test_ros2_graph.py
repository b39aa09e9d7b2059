"""The embedded `ros2` against a running plant + fixed_responder (one graph for all verbs).

Each test runs the installed `ros2` command as a user would, in the graph's
private domain, and checks what it prints and its exit code against what the
nodes really are (names, types, values), in upstream ros2cli's format.
"""
import pytest
import yaml

from drive_testing.harness import wait_until

pytestmark = pytest.mark.ros


def _settled(ros2, args, ready, what):
    """ros2 <args> once its output shows the whole graph (discovery without a daemon can lag on
    a loaded machine: as a user would, ask again), the output."""
    outputs = []

    def ask() -> bool:
        result = ros2(*args)
        outputs.append(result.out)
        return result.code == 0 and ready(result.out)

    wait_until(ask, 120.0, 0.5, what)
    return outputs[-1]


def test_node_list_and_info(drive_graph):
    ros2 = drive_graph
    names = _settled(ros2, ('node', 'list'), lambda out: {'/plant', '/fixed_responder'} <= set(out.split()),
                     'both nodes listed').split()
    assert not any(n.startswith('/_') for n in names), names          # hidden: not even ours
    _settled(ros2, ('node', 'list', '-c'), lambda out: out.strip() == str(len(names)), 'the count')

    info = ros2.ok('node', 'info', '/plant')
    lines = info.splitlines()
    assert lines[0] == '/plant'
    headers = [l for l in lines if l and not l.startswith('    ')]
    assert headers == ['/plant', '  Subscribers:', '  Publishers:', '  Service Servers:',
                       '  Service Clients:', '  Action Servers:', '  Action Clients:']
    publishers = lines[lines.index('  Publishers:'):lines.index('  Service Servers:')]
    assert '    /plant/state: dtc_msgs/msg/PlantState' in publishers
    assert '    /clock: rosgraph_msgs/msg/Clock' in publishers
    assert '    /parameter_events: rcl_interfaces/msg/ParameterEvent' in publishers
    servers = lines[lines.index('  Service Servers:'):lines.index('  Service Clients:')]
    assert '    /plant/reset_protection: dtc_msgs/srv/ResetProtection' in servers
    assert '    /plant/get_parameters: rcl_interfaces/srv/GetParameters' in servers
    actions = lines[lines.index('  Action Servers:'):lines.index('  Action Clients:')]
    assert actions == ['  Action Servers:', '    /plant/run: dtc_msgs/action/Run']
    assert not any('/_action/' in l for l in lines)                    # hidden unless asked

    missing = ros2('node', 'info', '/no_such_node')
    assert missing.code == 1 and missing.err.strip() == 'Node not found'


def test_topic_list_and_info(drive_graph):
    ros2 = drive_graph
    listed = _settled(ros2, ('topic', 'list', '-t'),
                      lambda out: {'/plant/state [dtc_msgs/msg/PlantState]',
                                   '/drive/gate_command [dtc_msgs/msg/GateCommand]'} <= set(out.splitlines()),
                      'both nodes\' topics listed').splitlines()
    assert '/plant/state [dtc_msgs/msg/PlantState]' in listed
    assert '/drive/gate_command [dtc_msgs/msg/GateCommand]' in listed
    assert '/plant/state' in _settled(ros2, ('topic', 'list'), lambda out: '/plant/state' in out.splitlines(),
                                      '/plant/state listed').splitlines()

    # counts need both processes' endpoints discovered: give discovery the time a loaded machine needs
    info = _settled(ros2, ('topic', 'info', '/drive/measurement', '--spin-time', '3'),
                    lambda out: 'Subscription count: 0' not in out, 'both endpoints').splitlines()
    assert info == ['Type: dtc_msgs/msg/DriveMeasurement', 'Publisher count: 1', 'Subscription count: 1']
    verbose = _settled(ros2, ('topic', 'info', '-v', '/plant/state'),
                       lambda out: 'Node name: _NODE_NAME_UNKNOWN_' not in out, "the publisher's node known")
    assert verbose.startswith('Type: dtc_msgs/msg/PlantState\n\nPublisher count: 1\n\nNode name: plant\n'
                              'Node namespace: /\nTopic type: dtc_msgs/msg/PlantState\n')
    assert 'Endpoint type: PUBLISHER' in verbose and 'QoS profile:\n  Reliability: ' in verbose
    assert '\n\nSubscription count: ' in verbose

    unknown = ros2('topic', 'info', '/no_such_topic')
    assert unknown.code == 1 and "Unknown topic '/no_such_topic'" in unknown.err


def test_param_verbs_and_dump_load_round_trip(drive_graph, tmp_path):
    ros2 = drive_graph
    listed = ros2.ok('param', 'list', '/plant').splitlines()
    assert '  load.torque' in listed and '  sensors.current_offset' in listed
    everyone = ros2('param', 'list', '--spin-time', '3')      # every node: let discovery finish
    assert everyone.code == 0
    assert '/plant:\n' in everyone.out and '/fixed_responder:\n' in everyone.out, everyone.err
    typed = ros2.ok('param', 'list', '/plant', '--param-type').splitlines()
    assert '  load.torque (type: double)' in typed
    assert '  sensors.current_offset (type: double array)' in typed

    assert ros2.ok('param', 'get', '/plant', 'load.torque').strip() == 'Double value is: 0.2'
    assert ros2.ok('param', 'get', '/plant', 'load.torque', '--hide-type').strip() == '0.2'
    assert ros2.ok('param', 'get', '/plant', 'motor.file').strip() == 'String value is: ozturk_bldc'
    assert (ros2.ok('param', 'get', '/plant', 'sensors.current_offset').strip()
            == 'Double values are: [0.0, 0.0, 0.0]')
    assert ros2.ok('param', 'set', '/plant', 'load.torque', '0.3').strip() == 'Set parameter successful'
    assert ros2.ok('param', 'get', '/plant', 'load.torque').strip() == 'Double value is: 0.3'
    refused = ros2('param', 'set', '/plant', 'load.torque', '5000.0')
    assert refused.code == 0 and refused.err.startswith('Setting parameter failed')    # as upstream
    assert ros2.ok('param', 'get', '/plant', 'load.torque').strip() == 'Double value is: 0.3'

    described = ros2.ok('param', 'describe', '/plant', 'load.torque', 'motor.pole_pairs').splitlines()
    assert described[:2] == ['Parameter name: load.torque', '  Type: double']
    assert '  Constraints:' in described
    assert '    Min value: -1000.0' in described and '    Max value: 1000.0' in described
    assert 'Parameter name: motor.pole_pairs' in described and '  Type: integer' in described

    dumped = ros2.ok('param', 'dump', '/plant')
    document = yaml.safe_load(dumped)                      # YAML 1.1, as upstream's load reads it
    params = document['/plant']['ros__parameters']
    assert params['load']['torque'] == 0.3
    assert params['motor']['file'] == 'ozturk_bldc'
    assert params['front_end']['max_step'] == 1e-06 and isinstance(params['front_end']['max_step'], float)
    assert params['sensors']['current_offset'] == [0.0, 0.0, 0.0]
    floats = [v for v in _leaves(params) if isinstance(v, str) and _looks_numeric(v)]
    assert not floats, f'numbers dumped as strings: {floats}'

    path = tmp_path / 'plant.yaml'
    path.write_text(dumped)
    assert ros2.ok('param', 'set', '/plant', 'load.torque', '0.1').strip() == 'Set parameter successful'
    loaded = ros2.ok('param', 'load', '/plant', str(path)).splitlines()
    assert 'Set parameter load.torque successful' in loaded
    assert ros2.ok('param', 'get', '/plant', 'load.torque').strip() == 'Double value is: 0.3'
    assert yaml.safe_load(ros2.ok('param', 'dump', '/plant')) == document

    missing = ros2('param', 'get', '/no_such_node', 'x', '--timeout', '1')
    assert missing.code == 1 and missing.err.strip() == 'Node not found'


def _leaves(tree):
    for value in tree.values():
        if isinstance(value, dict):
            yield from _leaves(value)
        else:
            yield value


def _looks_numeric(text):
    try:
        float(text)
        return True
    except ValueError:
        return False


def test_service_verbs(drive_graph):
    ros2 = drive_graph
    service = '/plant/reset_protection [dtc_msgs/srv/ResetProtection]'
    assert service in _settled(ros2, ('service', 'list', '-t'), lambda out: service in out.splitlines(),
                               'the plant\'s service listed').splitlines()
    assert _settled(ros2, ('service', 'type', '/plant/reset_protection'), lambda out: out.strip(),
                    'its type').strip() == 'dtc_msgs/srv/ResetProtection'
    called = ros2.ok('service', 'call', '/plant/reset_protection', 'dtc_msgs/srv/ResetProtection')
    assert 'requester: making request: dtc_msgs.srv.ResetProtection_Request()' in called
    assert 'response:\ndtc_msgs.srv.ResetProtection_Response(success=True' in called
    unknown = ros2('service', 'type', '/no_such_service')
    assert unknown.code == 1


def test_action_verbs_echo_and_bag(drive_graph, tmp_path):
    """send_goal drives the plant; echo sees its state; bag record/info/play see the same run."""
    ros2 = drive_graph
    assert _settled(ros2, ('action', 'list', '-t'), lambda out: out.strip(),
                    'the plant\'s action listed').splitlines() == ['/plant/run [dtc_msgs/action/Run]']
    info = _settled(ros2, ('action', 'info', '/plant/run'), lambda out: 'Action servers: 1' in out,
                    'its server').splitlines()
    assert info == ['Action: /plant/run', 'Action clients: 0', 'Action servers: 1', '    /plant']

    echo = ros2.start('topic', 'echo', '--once', '/plant/state', '--field', 'step', '--timeout', '120',
                      name='echo')
    bag = tmp_path / 'bag'
    recorder = ros2.start('bag', 'record', '-o', str(bag), '/plant/state', name='record')
    recorder.wait_for_output('recorder ready')
    # echo subscribes once it has discovered the topic's type: the run must not start before
    # (on a loaded machine the whole goal can pass before echo's subscription matches).
    wait_until(lambda: _subscribers(ros2, '/plant/state') >= 2, 120.0,
               what='echo and the recorder subscribed to /plant/state')
    goal = ros2.ok('action', 'send_goal', '--feedback', '/plant/run', 'dtc_msgs/action/Run',
                   '{target_time: 0.06}')
    assert 'Goal accepted with ID: ' in goal
    assert 'Result:\n    success: true\nfinal_step: 2400\n' in goal
    assert goal.rstrip().endswith('Goal finished with status: SUCCEEDED')
    assert 'Feedback:\n    sim_time: 0.05\nstep: 2000\n' in goal          # every 0.05 s of sim time
    assert echo.process.wait(timeout=60) == 0
    step, separator = echo.output().strip().splitlines()[-2:]
    assert 0 <= int(step) <= 2400 and separator == '---'

    assert recorder.interrupt() == 0
    bag_info = ros2.ok('bag', 'info', str(bag))
    count = [l for l in bag_info.splitlines() if 'Topic: /plant/state' in l]
    assert count and '| Type: dtc_msgs/msg/PlantState | Count: ' in count[0]
    assert int(count[0].split('Count: ')[1].split()[0]) > 0
    assert 'Storage id:        mcap' in bag_info

    replayed = ros2.start('topic', 'echo', '--once', '/replayed_state', 'dtc_msgs/msg/PlantState',
                          '--field', 'step', '--timeout', '120', name='echo_replayed')
    play = ros2.start('bag', 'play', str(bag), '-r', '10', '--loop', '--remap', '/plant/state:=/replayed_state',
                      name='play')        # looped: the echo's subscription matches during some pass
    assert replayed.process.wait(timeout=120) == 0
    assert 0 <= int(replayed.output().strip().splitlines()[-2]) <= 2400
    assert play.interrupt() == 0, play.output()

    recorded = int(count[0].split('Count: ')[1].split()[0])
    whole = ros2('bag', 'play', str(bag), '-r', '100')
    assert whole.code == 0 and f'replay done: {recorded} messages published' in whole.out + whole.err
    skipped = ros2('bag', 'play', str(bag), '--start-offset', '1000')     # past the end: nothing
    assert skipped.code == 0 and 'replay done: 0 messages published' in skipped.out + skipped.err


def test_topic_pub_echo_and_hz(drive_graph):
    ros2 = drive_graph
    echo = ros2.start('topic', 'echo', '--once', '/cli_duty', 'dtc_msgs/msg/DutyCommand', '--timeout', '120',
                      name='echo_duty')
    published = ros2.ok('topic', 'pub', '--once', '-w', '1', '/cli_duty', 'dtc_msgs/msg/DutyCommand',
                        '{step: 7, duty: 1e-06, enable: true}')
    assert 'publishing #1: dtc_msgs.msg.DutyCommand(' in published
    assert echo.process.wait(timeout=60) == 0
    message = yaml.safe_load(echo.output().split('---')[0])
    assert message['step'] == 7 and message['duty'] == 1e-06 and message['enable'] is True
    assert message['header'] == {'stamp': {'sec': 0, 'nanosec': 0}, 'frame_id': ''}

    publisher = ros2.start('topic', 'pub', '-r', '20', '/cli_rate', 'dtc_msgs/msg/DutyCommand', '{duty: 0.5}',
                           name='pub_rate')
    hz = ros2.start('topic', 'hz', '/cli_rate', '--wall-time', name='hz')
    text = hz.wait_for_output('average rate: ', timeout=90)
    rate = float(text.split('average rate: ')[1].split()[0])
    assert 5.0 < rate < 40.0                               # 20 Hz requested; loose: shared CPU
    for command in (hz, publisher):                        # Ctrl-C: code 2, as upstream
        assert command.interrupt() == 2, command.output()[-3000:]

    bad = ros2('topic', 'pub', '--once', '/cli_duty', 'dtc_msgs/msg/DutyCommand', '{no_such_field: 1}')
    assert bad.code == 1 and "no_such_field" in bad.err


def _subscribers(ros2, topic: str) -> int:
    """Subscription count of topic, as `ros2 topic info` sees it."""
    out = ros2('topic', 'info', topic).out
    return int(out.split('Subscription count: ')[1].split()[0]) if 'Subscription count: ' in out else 0


def test_bag_reindex_completes_the_bag_of_a_killed_recorder(drive_graph, tmp_path):
    """Needs drive_logger.bag_reindex: the recorder is SIGKILLed after a
    run; `ros2 bag reindex` gives the bag its metadata.yaml, and `ros2 bag info` then reports exactly
    the messages that were on disk, nothing invented."""
    import os
    import signal

    from drive_logger.bag_reader import BagReader, BagReadError

    ros2 = drive_graph
    bag = tmp_path / 'killed'
    recorder = ros2.start('bag', 'record', '-o', str(bag), '/plant/state', name='record_killed')
    recorder.wait_for_output('recorder ready')

    def flushed() -> int:
        try:
            return sum(1 for _ in BagReader(bag, salvage=True).messages())
        except BagReadError:        # no .mcap file written yet
            return 0

    wait_until(lambda: _subscribers(ros2, '/plant/state') >= 1, 120.0, what='the recorder subscribed')
    # The recorder joins a plant that is already up: until the plant's publisher has matched its
    # subscription (asynchronous, slower under load) a run records nothing, so run again until a
    # run reached the disk (the recorder flushes every 0.5 s of wall time).
    for _ in range(6):
        ros2.ok('action', 'send_goal', '/plant/run', 'dtc_msgs/action/Run', '{target_time: 0.06, relative: true}')
        if wait_until(flushed, 10.0, 0.1, raise_timeout=False):
            break
    assert flushed(), 'six runs of the plant and nothing of /plant/state reached the recorder\'s bag'
    os.killpg(recorder.process.pid, signal.SIGKILL)
    recorder.process.wait(timeout=30)
    assert not (bag / 'metadata.yaml').exists()
    on_disk = flushed()
    assert on_disk > 0, 'the recorder flushed nothing before it was killed'

    assert ros2('bag', 'info', str(bag)).code == 1            # not readable before the reindex
    reindexed = ros2('bag', 'reindex', str(bag))
    assert reindexed.code == 0, reindexed.err
    assert (bag / 'metadata.yaml').is_file()
    info = ros2.ok('bag', 'info', str(bag))
    line = next(l for l in info.splitlines() if 'Topic: /plant/state' in l)
    assert int(line.split('Count: ')[1].split()[0]) == on_disk


MUTE_NODE = '''
import time, rclpy
rclpy.init()
node = rclpy.create_node('mute')     # advertises the parameter services, never spins: never answers
print('mute up', flush=True)
time.sleep(600)
'''


def test_param_verbs_never_hang_on_a_node_that_does_not_answer(drive_graph, tmp_path):
    """A node that advertises parameter services but never answers costs the
    command its time-out and a one-line report, never a hang."""
    import subprocess
    import sys

    from drive_testing.harness import wait_until

    ros2 = drive_graph
    log = open(tmp_path / 'mute.out', 'w')
    mute = subprocess.Popen([sys.executable, '-c', MUTE_NODE], env=ros2.env, stdout=log, stderr=subprocess.STDOUT)
    try:
        wait_until(lambda: '/mute' in ros2('node', 'list').out, 60.0, what='/mute in the graph')
        everyone = ros2('param', 'list', '--spin-time', '3', '--service-timeout', '2')
        assert everyone.code == 0
        assert '/plant:\n  base_tick\n' in everyone.out and '/mute:' not in everyone.out
        assert "list_parameters service of node '/mute': no answer within 2 s" in everyone.err
        one = ros2('param', 'get', '/mute', 'use_sim_time', '--service-timeout', '2')
        assert one.code == 1 and one.err.strip() == "get_parameters service of node '/mute': no answer within 2 s"
    finally:
        mute.kill()
        mute.wait(timeout=10)
        log.close()
