"""live_view: the running graph in the Foxglove WebSocket protocol.

The core (decimation, bounded hand-off, parameter names) is tested without
ROS; the node is tested with a real graph (plant + dtc_controller in a
private domain) and a plain ``websockets`` client speaking the protocol the
Foxglove app speaks.
"""
from __future__ import annotations

import json
import re
import socket
import struct
import threading
import time
from pathlib import Path

import pytest

from drive_logger.core import live_view as core

MOTORS = Path(__file__).resolve().parents[2] / 'bldc_plant_sim' / 'motors'
PLANT = {'motor.file': 'ozturk_bldc', 'dc_link.voltage': 56.57}
DTC = {'mode': 'two_phase_six_switch', 'backemf_table_path': str(MOTORS / 'ozturk_bldc_backemf.csv'),
       'torque_reference': 0.5}
SUBPROTOCOL = 'foxglove.sdk.v1'       # what foxglove-sdk's server negotiates (and the Foxglove app offers)
OP_MESSAGE_DATA, OP_TIME = 1, 2       # binary server opcodes


# ------------------------------------------------------------------ core, no ROS
def _cdr(sec: int, nanosec: int, big_endian: bool = False) -> bytes:
    header = b'\x00\x00\x00\x00' if big_endian else b'\x00\x01\x00\x00'
    return header + struct.pack('>iI' if big_endian else '<iI', sec, nanosec) + b'\x00' * 12


def test_stamp_is_read_from_the_serialized_header():
    from rclpy.serialization import serialize_message
    from dtc_msgs.msg import PlantState
    from drive_logger.message_definitions import cdr_stamp_ns
    msg = PlantState(step=7)
    msg.header.stamp.sec, msg.header.stamp.nanosec = 3, 250_000
    assert cdr_stamp_ns(serialize_message(msg)) == 3_000_250_000
    assert cdr_stamp_ns(_cdr(1, 5, big_endian=True)) == 1_000_000_005
    with pytest.raises(ValueError):
        cdr_stamp_ns(b'\x00\x01\x00')


def test_decimator_passes_one_message_per_period_on_a_fixed_grid():
    from drive_common.telemetry import Decimator
    decimator = Decimator(core.check_period(0.001))
    stamps = [k * 25_000 for k in range(400)]              # 25 us samples, 10 ms
    passed = [s for s in stamps if decimator.keep(s)]
    assert passed == [k * 1_000_000 for k in range(10)]
    assert decimator.keep(0)                               # time went back: a new run starts over
    every = Decimator(0.0)
    assert all(every.keep(s) for s in (5, 5, 6))
    for bad in (-1.0, 10.5):
        with pytest.raises(ValueError):
            core.check_period(bad)


def test_outbox_drops_the_oldest_and_counts_it():
    box = core.Outbox(3)
    for item in range(5):
        box.put(item)
    assert box.take_all(0.0) == [2, 3, 4] and box.dropped == 2
    assert box.take_all(0.0) == []
    with pytest.raises(ValueError):
        core.Outbox(0)


def test_parameter_names_and_values():
    assert core.parameter_name('/plant', 'load.torque') == '/plant.load.torque'
    assert core.split_parameter_name('/plant.load.torque') == ('/plant', 'load.torque')
    assert core.by_node(['/a.x', '/b.y', '/a.z']) == {'/a': ['x', 'z'], '/b': ['y']}
    for bad in ('plant.x', '/plant', '/.x', '/plant.'):
        with pytest.raises(ValueError, match='/node.parameter'):
            core.split_parameter_name(bad)
    assert core.coerce(1, 0.5) == 1.0 and isinstance(core.coerce(1, 0.5), float)
    assert core.coerce([1, 2.5], [0.0]) == [1.0, 2.5]
    assert core.coerce(True, 0.5) is True                  # not silently turned into 1.0
    assert core.coerce('abc', 0.5) == 'abc'                # the node's own check refuses it
    assert core.type_hint(2.0) == 'Float64' and core.type_hint(2) is None


# --------------------------------------------------------------- the node, with a graph
class Viewer:
    """A Foxglove WebSocket protocol client (the app's side) over the websockets package."""

    def __init__(self, port: int, receive_buffer: int | None = None, **kwargs) -> None:
        from websockets.sync.client import connect
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        if receive_buffer:          # a small TCP window: a viewer that stops reading stalls the sender at once
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, receive_buffer)
        sock.connect(('127.0.0.1', port))
        self.ws = connect(f'ws://127.0.0.1:{port}', sock=sock, subprotocols=[SUBPROTOCOL],
                          open_timeout=30, legacy=True, **kwargs)
        self.server_info = None
        self.channels: dict[int, dict] = {}
        self.texts: list[dict] = []
        self.times: list[int] = []
        self.subscriptions: dict[int, dict] = {}
        self.messages: dict[str, list[tuple[int, bytes]]] = {}

    def pump(self, until, timeout: float, what: str):
        """Read frames until until() is truthy; fail after timeout s."""
        deadline = time.monotonic() + timeout
        while True:
            value = until()
            if value:
                return value
            left = deadline - time.monotonic()
            assert left > 0, (f'timed out waiting for {what}; last texts: {str(self.texts[-2:])[:300]}; '
                              f'messages: { {t: len(m) for t, m in self.messages.items()} }')
            try:
                frame = self.ws.recv(timeout=min(left, 1.0))
            except TimeoutError:
                continue
            if isinstance(frame, str):
                message = json.loads(frame)
                self.texts.append(message)
                if message['op'] == 'serverInfo':
                    self.server_info = message
                elif message['op'] == 'advertise':
                    self.channels.update({c['id']: c for c in message['channels']})
            elif frame[0] == OP_MESSAGE_DATA:
                subscription, log_time = struct.unpack_from('<IQ', frame, 1)
                topic = self.subscriptions[subscription]['topic']
                self.messages.setdefault(topic, []).append((log_time, bytes(frame[13:])))
            elif frame[0] == OP_TIME:
                self.times.append(struct.unpack_from('<Q', frame, 1)[0])

    def channel(self, topic: str) -> dict | None:
        return next((c for c in self.channels.values() if c['topic'] == topic), None)

    def subscribe(self, topics) -> None:
        subs = []
        for topic in topics:
            channel = self.channel(topic)
            sub_id = len(self.subscriptions) + 1
            self.subscriptions[sub_id] = channel
            subs.append({'id': sub_id, 'channelId': channel['id']})
        self.ws.send(json.dumps({'op': 'subscribe', 'subscriptions': subs}))

    def request(self, message: dict) -> None:
        self.ws.send(json.dumps(message))

    def reply(self, request_id: str):
        return next((m for m in self.texts if m.get('op') == 'parameterValues' and m.get('id') == request_id), None)

    def close(self) -> None:
        self.ws.close()


def _start_live_view(start_node, **parameters):
    from drive_testing.harness import wait_until
    live = start_node('drive_logger', 'live_view', parameters={'port': 0, **parameters})
    match = wait_until(lambda: re.search(r'live view ready: ws://[\d.]+:(\d+)', live.output()) or not live.alive(),
                       60.0, what='live_view ready')
    assert live.alive(), live.output()
    return live, int(match.group(1))


def _decode_with_schema(channel: dict, payload: bytes):
    """Decode with nothing but the advertised schema (mcap-ros2-support, no installed types)."""
    from mcap.records import Schema
    from mcap_ros2.decoder import DecoderFactory
    schema = Schema(id=1, name=channel['schemaName'], encoding=channel['schemaEncoding'],
                    data=channel['schema'].encode())
    return DecoderFactory().decoder_for(channel['encoding'], schema)(payload)


def test_viewer_lists_subscribes_decodes_and_sets_parameters(start_node, ros_session):
    from rclpy.serialization import deserialize_message
    from drive_logger.message_definitions import full_definition
    from drive_logger.ros_types import message_class

    start_node('dtc_controller', 'dtc_controller', parameters=DTC)
    live, port = _start_live_view(start_node)
    start_node('bldc_plant_sim', 'plant', parameters={**PLANT, 'run_until': 5.0})
    viewer = Viewer(port)
    try:
        topics = ['/plant/state', '/dtc/status', '/pfc/status', '/diagnostics']
        viewer.pump(lambda: viewer.server_info and all(viewer.channel(t) for t in topics), 30.0, 'channels')
        assert {'parameters', 'time'} <= set(viewer.server_info['capabilities'])
        for topic in topics:
            channel = viewer.channel(topic)
            assert channel['encoding'] == 'cdr' and channel['schemaEncoding'] == 'ros2msg'
            assert channel['schema'] == full_definition(channel['schemaName'])     # full concatenated definition
        assert viewer.channel('/plant/state')['schemaName'] == 'dtc_msgs/msg/PlantState'

        viewer.subscribe(['/plant/state', '/dtc/status', '/diagnostics'])
        viewer.pump(lambda: len(viewer.messages.get('/plant/state', [])) >= 5
                    and len(viewer.messages.get('/dtc/status', [])) >= 5 and viewer.times, 120.0, 'messages')
        for topic in ('/plant/state', '/dtc/status'):
            channel = viewer.channel(topic)
            decoded = [deserialize_message(payload, message_class(channel['schemaName']))
                       for _, payload in viewer.messages[topic]]
            stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in decoded]
            # the frame's log time is the message's sim time; 1 kHz of sim time, not every sample
            assert stamps == [log_time for log_time, _ in viewer.messages[topic]]
            assert stamps == sorted(stamps), stamps[:10]
            assert len({s // 1_000_000 for s in stamps}) == len(stamps), stamps[:10]   # one per ms grid cell
            by_schema = _decode_with_schema(channel, viewer.messages[topic][-1][1])
            assert by_schema.step == decoded[-1].step
        assert viewer.times[-1] > 0                          # server time = sim time from /clock

        # parameters: get, set (acts on the node and in dtc/status), a refused value keeps the old one
        viewer.request({'op': 'getParameters', 'parameterNames': ['/dtc_controller.torque_reference'], 'id': 'g'})
        got = viewer.pump(lambda: viewer.reply('g'), 30.0, 'getParameters reply')
        assert got['parameters'] == [{'name': '/dtc_controller.torque_reference', 'type': 'float64', 'value': 0.5}]
        viewer.request({'op': 'getParameters', 'parameterNames': [], 'id': 'all'})
        names = {p['name'] for p in viewer.pump(lambda: viewer.reply('all'), 60.0, 'all parameters')['parameters']}
        assert {'/plant.load.torque', '/dtc_controller.mode'} <= names

        viewer.request({'op': 'setParameters', 'id': 's',
                        'parameters': [{'name': '/dtc_controller.torque_reference', 'value': 0.8}]})
        assert viewer.pump(lambda: viewer.reply('s'), 30.0, 'set reply')['parameters'][0]['value'] == 0.8
        probe = ros_session.node('live_view_probe')
        from rclpy.parameter_client import AsyncParameterClient
        client = AsyncParameterClient(probe, '/dtc_controller')
        assert client.wait_for_services(30.0)
        future = client.get_parameters(['torque_reference'])
        from drive_testing.harness import wait_until
        wait_until(future.done, 30.0, what='get_parameters')
        assert future.result().values[0].double_value == 0.8
        status = message_class('dtc_msgs/msg/DtcStatus')
        seen = len(viewer.messages['/dtc/status'])
        viewer.pump(lambda: any(deserialize_message(p, status).torque_reference == 0.8
                                for _, p in viewer.messages['/dtc/status'][seen:]), 120.0, 'T* = 0.8 in dtc/status')

        viewer.request({'op': 'setParameters', 'id': 'bad',
                        'parameters': [{'name': '/dtc_controller.torque_reference', 'value': 'high'}]})
        assert viewer.pump(lambda: viewer.reply('bad'), 30.0, 'refusal')['parameters'][0]['value'] == 0.8
        refusal = next(m for m in viewer.texts if m['op'] == 'status')
        assert 'refused torque_reference' in refusal['message'] and refusal['level'] >= 1

        # a change made through ROS (as `ros2 param set` does) reaches a viewer subscribed to updates
        def pushed(value):
            return lambda: any(m.get('op') == 'parameterValues' and 'id' not in m
                               and m['parameters'] == [{'name': '/dtc_controller.torque_reference',
                                                        'type': 'float64', 'value': value}] for m in viewer.texts)
        viewer.request({'op': 'subscribeParameterUpdates', 'parameterNames': ['/dtc_controller.torque_reference']})
        viewer.pump(pushed(0.8), 30.0, 'the current value pushed on subscription')
        from rclpy.parameter import Parameter
        future = client.set_parameters([Parameter('torque_reference', value=0.6)])
        wait_until(future.done, 30.0, what='set_parameters')
        assert future.result().results[0].successful
        viewer.pump(pushed(0.6), 30.0, 'the update pushed to the viewer')

        # its own health on /diagnostics, decoded like any other message
        diag_type = message_class('diagnostic_msgs/msg/DiagnosticArray')
        own = viewer.pump(lambda: next((s for _, p in viewer.messages.get('/diagnostics', [])
                                        for s in deserialize_message(p, diag_type).status if s.name == 'live_view'),
                                       None), 60.0, 'live_view diagnostics')
        values = {kv.key: kv.value for kv in own.values}
        assert {'dropped_frames', 'viewers_subscribed', 'forwarded /plant/state'} <= set(values), values
    finally:
        viewer.close()
    assert live.alive(), live.output()


def test_parameter_changes_pushed_while_a_viewer_subscribes_and_unsubscribes_never_hang_the_server(
        start_node, ros_session):
    """The SDK holds its parameter-subscription lock while it waits for the GIL in the listener;
    a push made from Python at that moment (a ROS parameter event) used to hang the process."""
    from rclpy.parameter import Parameter
    live, port = _start_live_view(start_node, topics=['/diagnostics'])
    source = ros_session.node('parameter_source')
    source.declare_parameter('level', 0.0)
    name = '/parameter_source.level'
    stop = threading.Event()

    def change() -> None:                      # one ParameterEvent per set, as `ros2 param set` makes
        level = 0
        while not stop.wait(0.002):
            level += 1
            source.set_parameters([Parameter('level', value=float(level))])
    changer = threading.Thread(target=change, daemon=True)
    viewer = Viewer(port)
    try:
        changer.start()

        def pushed_since(start: int) -> int:
            return sum(1 for m in viewer.texts[start:] if m.get('op') == 'parameterValues' and 'id' not in m
                       and [p['name'] for p in m['parameters']] == [name])
        viewer.request({'op': 'subscribeParameterUpdates', 'parameterNames': [name]})
        viewer.pump(lambda: pushed_since(0) >= 3, 60.0, 'changes made through ROS pushed to the viewer')
        for _ in range(200):
            viewer.request({'op': 'unsubscribeParameterUpdates', 'parameterNames': [name]})
            viewer.request({'op': 'subscribeParameterUpdates', 'parameterNames': [name]})
        seen = len(viewer.texts)
        viewer.pump(lambda: pushed_since(seen) >= 3, 60.0, 'pushes after 200 unsubscribe/subscribe rounds')
        viewer.request({'op': 'getParameters', 'parameterNames': [name], 'id': 'after'})
        value = viewer.pump(lambda: viewer.reply('after'), 30.0, 'a getParameters reply')['parameters'][0]['value']
        assert 1.0 <= value <= source.get_parameter('level').value     # a real value of the source's
    finally:
        stop.set()
        changer.join()
        viewer.close()
    assert live.alive(), live.output()
    assert 'parameter update not pushed' not in live.output()


def test_a_viewer_that_never_reads_does_not_stall_the_plant(start_node):
    from rclpy.serialization import deserialize_message
    from diagnostic_msgs.msg import DiagnosticArray
    from drive_testing.harness import wait_until
    from websockets.exceptions import ConnectionClosed

    every = {'telemetry.live_period': 0.0}      # the nodes' live topics at full rate
    start_node('dtc_controller', 'dtc_controller', parameters={**DTC, **every})
    # every sample taken and forwarded, a tiny SDK outbox: the stalled viewer's queue overflows at once
    live, port = _start_live_view(start_node, decimation_period=0.0, time_period=0.0, message_backlog_size=8,
                                  qos_depth=64, batch_period=0.0)
    stalled = Viewer(port, receive_buffer=4096, max_queue=1, ping_interval=None)   # stops reading the socket
    stalled.pump(lambda: stalled.channel('/plant/state') and stalled.channel('/dtc/status'), 30.0, 'channels')
    stalled.subscribe(['/plant/state', '/dtc/status'])
    try:
        # 0.3 s at 25 us: 12 001 frames on each topic, several MB, more than the kernel's socket
        # buffers (tcp_wmem max 4 MiB) can hold for a viewer that does not read
        plant = start_node('bldc_plant_sim', 'plant', parameters={**PLANT, 'run_until': 0.3, **every})
        line = wait_until(lambda: re.search(r'run_until finished: (.*)', plant.output()), 300.0,
                          what='the plant to reach run_until with a stalled viewer')
        assert line.group(1).startswith('reached t = 0.3') and 'fault' not in line.group(1), plant.output()[-2000:]
        assert live.alive(), live.output()

        # the live view still serves a new viewer, and says how many plant/state frames it forwarded
        fresh = Viewer(port)
        fresh.pump(lambda: fresh.channel('/diagnostics'), 30.0, 'channels for a new viewer')
        fresh.subscribe(['/diagnostics'])

        def forwarded():
            counts = [int({kv.key: kv.value for kv in status.values}['forwarded /plant/state'])
                      for _, payload in fresh.messages.get('/diagnostics', [])
                      for status in deserialize_message(payload, DiagnosticArray).status
                      if status.name == 'live_view']
            # the run is over: two reports in a row with the same count
            return counts[-1] if len(counts) >= 2 and counts[-1] == counts[-2] > 0 else None
        sent = fresh.pump(forwarded, 60.0, 'two equal live_view reports of frames forwarded after the run')
        fresh.close()
    finally:
        stalled.ws.close_timeout = 1

    # the stalled viewer now reads what reached it: the SDK dropped frames for it (or dropped it)
    try:
        stalled.pump(lambda: False, 5.0, 'nothing')
    except AssertionError:
        pass
    except ConnectionClosed:
        pass
    received = len(stalled.messages.get('/plant/state', []))
    print(f'stalled viewer received {received} of {sent} plant/state frames')
    assert received < sent, (received, sent)
    threading.Thread(target=stalled.close, daemon=True).start()


def test_bad_parameters_exit_2_with_the_reason(start_node):
    for parameters, expected in (({'decimation_period': -1.0}, 'decimation period'),
                                 ({'topics': ['/nowhere']}, "unknown type of '/nowhere'"),
                                 ({'topic_periods': ['plant/state']}, 'not name=seconds')):
        process = start_node('drive_logger', 'live_view', parameters={'port': 0, **parameters})
        assert process.process.wait(timeout=60) == 2, process.output()
        assert expected in process.output() and 'Traceback' not in process.output(), process.output()
    _, port = _start_live_view(start_node)
    taken = start_node('drive_logger', 'live_view', parameters={'port': port}, node_name='live_view_2')
    assert taken.process.wait(timeout=60) == 2, taken.output()
    assert f'cannot serve on 127.0.0.1:{port}' in taken.output() and 'Traceback' not in taken.output()


def test_run_scenario_live_needs_the_ros_graph(capsys):
    from drive_bringup.runner_cli import main
    assert main(['two_phase_six_switch_torque_step', '--live', '--headless']) == 2
    assert '--live watches the ROS graph' in capsys.readouterr().err


def test_layout_plots_real_fields_of_the_served_topics():
    """Every message path of the shipped layout names a field of the topic's message type."""
    from ament_index_python.packages import get_package_share_directory
    from drive_logger.graph_topics import known_type
    from drive_logger.ros_types import message_class
    layout = json.loads((Path(get_package_share_directory('drive_logger')) / 'layouts' / 'dtc_live.json').read_text())
    paths = [p['value'] for config in layout['configById'].values()
             for p in config.get('paths', []) + ([config['xAxisPath']] if 'xAxisPath' in config else [])]
    assert len(paths) >= 15
    for path in paths:
        match = re.fullmatch(r'(/[a-z_/]+)\.([a-z_]+)(?:\[(\d)\])?', path)
        assert match, path
        topic, field, index = match.groups()
        assert topic in _served_by_default(), path
        fields = message_class(known_type(topic)).get_fields_and_field_types()
        assert field in fields, path
        assert (index is not None) == fields[field].startswith('double['), path   # arrays indexed, scalars not
    assert {'Parameters!params', 'DiagnosticSummary!diag'} <= set(layout['configById'])
    locus = layout['configById']['Plot!locus']
    assert locus['xAxisVal'] == 'custom' and locus['xAxisPath']['value'] == '/dtc/status.flux_alpha'


def _served_by_default():
    from drive_logger.live_view import DEFAULT_TOPICS
    return {'/' + name.lstrip('/') for name in DEFAULT_TOPICS}
