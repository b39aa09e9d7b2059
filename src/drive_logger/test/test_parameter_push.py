"""ParameterPush has the Foxglove server push values to subscribed viewers (no ROS here)."""
from __future__ import annotations

import json
import socket

import pytest

from drive_common.waiting import wait_until
from drive_logger.parameter_push import ParameterPush, websocket_uri, wire_parameter


def test_values_go_on_the_wire_with_the_type_that_keeps_their_ros_type():
    assert wire_parameter('/n.a', 0.5) == {'name': '/n.a', 'value': 0.5, 'type': 'float64'}
    assert wire_parameter('/n.b', [1.0, 2.0]) == {'name': '/n.b', 'value': [1.0, 2.0], 'type': 'float64_array'}
    assert wire_parameter('/n.c', b'\x01\x02') == {'name': '/n.c', 'value': 'AQI=', 'type': 'byte_array'}
    assert wire_parameter('/n.c', [b'\x01', b'\x02']) == wire_parameter('/n.c', b'\x01\x02')   # as rclpy gives it
    assert wire_parameter('/n.d', 3) == {'name': '/n.d', 'value': 3}
    assert wire_parameter('/n.e', 'x') == {'name': '/n.e', 'value': 'x'}
    assert [websocket_uri(h, 9) for h in ('0.0.0.0', '', 'localhost', '::', '[::1]', '10.0.0.2')] == [
        'ws://127.0.0.1:9', 'ws://127.0.0.1:9', 'ws://localhost:9', 'ws://[::1]:9', 'ws://[::1]:9', 'ws://10.0.0.2:9']


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(('127.0.0.1', 0))
        return sock.getsockname()[1]


def test_pushed_values_reach_only_subscribers_and_survive_a_lost_connection():
    import foxglove
    from foxglove.websocket import Capability
    from websockets.sync.client import connect

    errors: list[str] = []

    class Listener:
        def __init__(self):
            self.set_by_viewer = []

        def on_get_parameters(self, client, names, request_id=None):
            return []

        def on_parameters_subscribe(self, names):
            pass

        def on_parameters_unsubscribe(self, names):
            pass

        def on_set_parameters(self, client, parameters, request_id=None):
            if push.is_push(request_id):
                return list(parameters)
            self.set_by_viewer.append([p.name for p in parameters])
            return []

    listener = Listener()
    server = foxglove.start_server(port=0, capabilities=[Capability.Parameters], server_listener=listener,
                                   context=foxglove.Context())
    push = ParameterPush('127.0.0.1', on_error=errors.append)
    viewer = connect(f'ws://127.0.0.1:{server.port}', subprotocols=['foxglove.sdk.v1'], proxy=None, legacy=True)
    try:
        def next_text(op: str, timeout: float = 60.0) -> dict:
            while True:
                frame = viewer.recv(timeout=timeout)
                if isinstance(frame, str) and json.loads(frame)['op'] == op:
                    return json.loads(frame)

        push.open(server.port)
        viewer.send(json.dumps({'op': 'subscribeParameterUpdates', 'parameterNames': ['/n.a']}))
        # a reply on the same connection: the subscription is in place before anything is pushed
        viewer.send(json.dumps({'op': 'getParameters', 'parameterNames': [], 'id': 'sync'}))
        assert next_text('parameterValues')['id'] == 'sync'
        push.publish({'/n.b': 9.0})                              # nobody subscribed: not sent
        push.publish({'/n.a': 0.25, '/n.b': 1.0})
        assert next_text('parameterValues')['parameters'] == [{'name': '/n.a', 'type': 'float64', 'value': 0.25}]
        push._ws.close()                                         # the link drops: the next push reconnects
        wait_until(push._link_lost.is_set, 60.0, what='the push saw its link drop')
        push.publish({'/n.a': 0.5})
        assert next_text('parameterValues')['parameters'] == [{'name': '/n.a', 'type': 'float64', 'value': 0.5}]
        push.publish({'/n.a': float('nan')})                     # JSON cannot carry it: said, not lost quietly
        wait_until(lambda: errors, 60.0, what='the refused value reported')
        assert len(errors) == 1 and errors[0].startswith('/n.a not pushed: Out of range float values'), errors
        assert listener.set_by_viewer == []                      # a push never reaches the ROS side
        assert not push.is_push('parameter-push-' + '0' * 32) and not push.is_push(None)
    finally:
        viewer.close()
        push.close()
        server.stop()
    push.publish({'/n.a': 1.0})                                  # closed: nothing queued, nothing said
    assert len(errors) == 1
    with pytest.raises(ConnectionError, match='cannot reach'):
        ParameterPush('127.0.0.1', on_error=errors.append, open_timeout=5.0).open(_free_port())
