"""ParameterPush has the Foxglove server push values to subscribed viewers (no ROS here)."""
from __future__ import annotations

import json

import pytest

from drive_logger.parameter_push import ParameterPush, loopback_host, wire_parameter


def test_values_go_on_the_wire_with_the_type_that_keeps_their_ros_type():
    assert wire_parameter('/n.a', 0.5) == {'name': '/n.a', 'value': 0.5, 'type': 'float64'}
    assert wire_parameter('/n.b', [1.0, 2.0]) == {'name': '/n.b', 'value': [1.0, 2.0], 'type': 'float64_array'}
    assert wire_parameter('/n.c', b'\x01\x02') == {'name': '/n.c', 'value': 'AQI=', 'type': 'byte_array'}
    assert wire_parameter('/n.d', 3) == {'name': '/n.d', 'value': 3}
    assert wire_parameter('/n.e', 'x') == {'name': '/n.e', 'value': 'x'}
    assert [loopback_host(h) for h in ('0.0.0.0', '', 'localhost', '::', '10.0.0.2')] == [
        '127.0.0.1', '127.0.0.1', '127.0.0.1', '::1', '10.0.0.2']


def test_pushed_values_reach_only_subscribers_and_survive_a_lost_connection():
    import foxglove
    from foxglove.websocket import Capability
    from websockets.sync.client import connect

    class Listener:
        def __init__(self):
            self.set_by_viewer = []

        def on_set_parameters(self, client, parameters, request_id=None):
            if push.is_push(request_id):
                return list(parameters)
            self.set_by_viewer.append([p.name for p in parameters])
            return []

    listener = Listener()
    context = foxglove.Context()
    server = foxglove.start_server(port=0, capabilities=[Capability.Parameters], server_listener=listener,
                                   context=context)
    push = ParameterPush('127.0.0.1', server.port)
    viewer = connect(f'ws://127.0.0.1:{server.port}', subprotocols=['foxglove.sdk.v1'], proxy=None, legacy=True)
    try:
        def next_values(timeout=30.0):
            while True:
                frame = viewer.recv(timeout=timeout)
                if isinstance(frame, str) and json.loads(frame)['op'] == 'parameterValues':
                    return json.loads(frame)['parameters']

        push.open()
        viewer.send(json.dumps({'op': 'subscribeParameterUpdates', 'parameterNames': ['/n.a']}))
        push.publish({'/n.b': 9.0})                              # nobody subscribed: not sent
        push.publish({'/n.a': 0.25, '/n.b': 1.0})
        assert next_values() == [{'name': '/n.a', 'type': 'float64', 'value': 0.25}]
        push._ws.close()                                         # the link drops: the next push reconnects
        push.publish({'/n.a': 0.5})
        assert next_values() == [{'name': '/n.a', 'type': 'float64', 'value': 0.5}]
        assert listener.set_by_viewer == []                      # a push never reaches the ROS side
        assert not push.is_push('parameter-push-' + '0' * 32) and not push.is_push(None)
        push.close()
        with pytest.raises(ConnectionError, match='closed'):
            push.publish({'/n.a': 1.0})
    finally:
        viewer.close()
        push.close()
        server.stop()
    with pytest.raises(ConnectionError, match='cannot reach'):
        ParameterPush('127.0.0.1', server.port or 1, open_timeout=2.0).open()
