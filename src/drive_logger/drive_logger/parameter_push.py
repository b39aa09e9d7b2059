"""Push parameter values to the viewers subscribed to them, without hanging the live view.

foxglove-sdk (0.30.3) holds its lock of parameter subscriptions while it calls
the Python listener's ``on_parameters_subscribe`` / ``on_parameters_unsubscribe``
(which needs the GIL), and ``WebSocketServer.publish_parameter_values`` takes
that lock while it holds the GIL. A push from any Python thread at the moment a
viewer subscribes or unsubscribes therefore hangs the whole process, for good.

The one push the SDK makes without the GIL is its answer to a client's
``setParameters``: it publishes the values the listener returned to every
subscribed client. So a :class:`ParameterPush` is a loopback client of the
server: it sends the values as a ``setParameters`` marked with a token made for
this process, and the listener, seeing :meth:`ParameterPush.is_push`, returns
them as they are instead of setting anything. Nothing in this module imports
rclpy.
"""
from __future__ import annotations

import base64
import json
import secrets
import threading

from websockets.exceptions import WebSocketException
from websockets.sync.client import connect

from drive_logger.core.live_view import type_hint

SUBPROTOCOL = 'foxglove.sdk.v1'
LINK_ERRORS = (WebSocketException, OSError, TimeoutError)
WIRE_TYPES = {'Float64': 'float64', 'Float64Array': 'float64_array', 'ByteArray': 'byte_array'}


def wire_parameter(name: str, value) -> dict:
    """One parameter as a client's setParameters carries it (Foxglove WebSocket protocol)."""
    out = {'name': name, 'value': value}
    hint = type_hint(value)
    if hint:
        out['type'] = WIRE_TYPES[hint]
    if hint == 'ByteArray':
        out['value'] = base64.b64encode(bytes(value)).decode('ascii')
    return out


def loopback_host(host: str) -> str:
    """Where a client on this machine reaches a server bound to host."""
    if host in ('', '0.0.0.0', 'localhost'):
        return '127.0.0.1'
    if host == '::':
        return '::1'
    return host


class ParameterPush:
    """A loopback WebSocket client that has the server push parameter values (see the module)."""

    def __init__(self, host: str, port: int, open_timeout: float = 10.0) -> None:
        self.token = f'parameter-push-{secrets.token_hex(16)}'
        address = loopback_host(host)
        self._uri = f'ws://[{address}]:{port}' if ':' in address else f'ws://{address}:{port}'
        self._open_timeout = open_timeout
        self._lock = threading.Lock()
        self._ws = None
        self._closed = False

    def open(self) -> None:
        """Connect now (publish() would on first use); ConnectionError with the reason."""
        with self._lock:
            try:
                self._ws or self._connect()
            except LINK_ERRORS as exc:
                raise ConnectionError(f'parameter push cannot reach {self._uri}: {exc}') from exc

    def is_push(self, request_id) -> bool:
        """Whether a setParameters request is this push's own (to be echoed, not set)."""
        return isinstance(request_id, str) and secrets.compare_digest(request_id.encode(), self.token.encode())

    def publish(self, values: dict[str, object]) -> None:
        """Have the server send '/node.param' -> value to the viewers subscribed to them.

        Connects on first use and once more after a lost connection; raises
        ConnectionError (with the reason) when the server cannot be reached.
        """
        if not values:
            return
        message = json.dumps({'op': 'setParameters', 'id': self.token,
                              'parameters': [wire_parameter(n, v) for n, v in values.items()]})
        with self._lock:
            for attempt in range(2):
                try:
                    (self._ws or self._connect()).send(message)
                    return
                except LINK_ERRORS as exc:
                    self._drop()
                    if attempt:
                        raise ConnectionError(f'parameter push to {self._uri} failed: {exc}') from exc

    def close(self) -> None:
        with self._lock:
            self._closed = True
            self._drop()

    def _connect(self):
        if self._closed:
            raise ConnectionError('parameter push closed')
        # loopback: no proxy, no compression, no keepalive; legacy=True is websockets' direct connect
        ws = connect(self._uri, subprotocols=[SUBPROTOCOL], open_timeout=self._open_timeout,
                     proxy=None, compression=None, ping_interval=None, legacy=True)
        # the server sends this client what it sends everyone (time, status, its own replies):
        # read and drop it, or the server's outbox for it fills and it is disconnected
        threading.Thread(target=self._drain, args=(ws,), name='parameter_push_drain', daemon=True).start()
        self._ws = ws
        return ws

    @staticmethod
    def _drain(ws) -> None:
        try:
            for _ in ws:
                pass
        except Exception:   # closed either way; publish() reconnects
            pass

    def _drop(self) -> None:
        if self._ws is not None:
            self._ws.close()
            self._ws = None
