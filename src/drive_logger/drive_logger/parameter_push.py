"""Push parameter values to the viewers subscribed to them, without hanging the live view.

foxglove-sdk (0.30.3) holds its parameter-subscription lock while it calls the listener's
``on_parameters_(un)subscribe`` (which needs the GIL), and ``publish_parameter_values`` takes
that lock while holding the GIL: a push at such a moment hangs the process. Its answer to a
client's ``setParameters`` is published without the GIL, so :class:`ParameterPush` is a
loopback client that sends the values as a ``setParameters`` marked with its token, which the
listener (:meth:`ParameterPush.is_push`) echoes instead of setting; its own thread sends the
latest value of each name. No rclpy here.
"""
from __future__ import annotations

import base64
import json
import secrets
import threading
from typing import Callable

from websockets.exceptions import WebSocketException
from websockets.sync.client import connect

from drive_logger.core.live_view import type_hint

SUBPROTOCOL = 'foxglove.sdk.v1'
LINK_ERRORS = (WebSocketException, OSError)        # (ConnectionError and TimeoutError are OSErrors)
WIRE_TYPES = {'Float64': 'float64', 'Float64Array': 'float64_array', 'ByteArray': 'byte_array'}


def wire_parameter(name: str, value) -> dict:
    """One parameter as a client's setParameters carries it (a ROS byte array as base64 ``byte_array``)."""
    if isinstance(value, list) and value and all(isinstance(v, bytes) for v in value):
        value = b''.join(value)
    out = {'name': name, 'value': value}
    hint = type_hint(value)
    if hint:
        out['type'] = WIRE_TYPES[hint]
    if hint == 'ByteArray':
        out['value'] = base64.b64encode(bytes(value)).decode('ascii')
    return out


def websocket_uri(host: str, port: int) -> str:
    """Where a client on this machine reaches a server bound to host:port (a wildcard: loopback)."""
    host = {'': '127.0.0.1', '0.0.0.0': '127.0.0.1', '::': '::1'}.get(host, host).strip('[]')
    return f'ws://[{host}]:{port}' if ':' in host else f'ws://{host}:{port}'


class ParameterPush:
    """A loopback WebSocket client that has the server push parameter values (see the module);
    on_error(reason) is called from the push thread for values that could not be pushed."""

    def __init__(self, host: str, on_error: Callable[[str], None], open_timeout: float = 10.0) -> None:
        self.token = f'parameter-push-{secrets.token_hex(16)}'
        self._host = host
        self._uri = ''
        self._on_error = on_error
        self._open_timeout = open_timeout
        self._pending: dict[str, object] = {}
        self._ready = threading.Condition()
        self._closed = False
        self._ws = None
        self._link_lost = threading.Event()
        self._thread: threading.Thread | None = None

    def open(self, port: int) -> None:
        """Connect to the server on port and start pushing; ConnectionError with the reason."""
        self._uri = websocket_uri(self._host, port)
        self._connect()
        self._thread = threading.Thread(target=self._push_loop, name='parameter_push', daemon=True)
        self._thread.start()

    def is_push(self, request_id) -> bool:
        """Whether a setParameters request is this push's own (to be echoed, not set)."""
        return isinstance(request_id, str) and secrets.compare_digest(request_id.encode(), self.token.encode())

    def publish(self, values: dict[str, object]) -> None:
        """Queue '/node.param' -> value for the viewers subscribed to them (latest value per name;
        nothing once closed); never waits."""
        with self._ready:
            if self._closed or not values:
                return
            self._pending.update(values)
            self._ready.notify()

    def close(self, timeout: float = 5.0) -> None:
        """Stop pushing (what is still queued is dropped) and close the link."""
        with self._ready:
            self._closed = True
            self._ready.notify()
        if self._thread is not None:
            self._thread.join(timeout)
        if self._ws is not None:
            self._ws.close()

    def _push_loop(self) -> None:
        while True:
            with self._ready:
                self._ready.wait_for(lambda: self._pending or self._closed)
                if self._closed:
                    return
                values, self._pending = self._pending, {}
            try:
                message = json.dumps({'op': 'setParameters', 'id': self.token,
                                      'parameters': [wire_parameter(n, v) for n, v in values.items()]},
                                     allow_nan=False)
            except (TypeError, ValueError) as exc:   # NaN, inf or a type JSON cannot carry
                self._on_error(f'{", ".join(values)} not pushed: {exc}')
                continue
            self._send(message, values)

    def _send(self, message: str, values: dict) -> None:
        for attempt in range(2):
            try:
                if self._link_lost.is_set():     # the server dropped us: do not write into a dead link
                    self._connect()
                self._ws.send(message)
                return
            except LINK_ERRORS as exc:
                self._link_lost.set()          # try once more on a new link
                if attempt and not self._closed:
                    self._on_error(f'{", ".join(values)} not pushed: {exc}')

    def _connect(self) -> None:
        if self._ws is not None:
            self._ws.close()
        try:
            # loopback: no proxy, no compression, no keepalive; legacy=True is websockets' direct connect
            ws = connect(self._uri, subprotocols=[SUBPROTOCOL], open_timeout=self._open_timeout,
                         proxy=None, compression=None, ping_interval=None, legacy=True)
        except LINK_ERRORS as exc:
            raise ConnectionError(f'parameter push cannot reach {self._uri}: {exc}') from exc
        self._ws = ws
        self._link_lost.clear()
        # the server sends this client what it sends everyone (time, status, its own replies):
        # read and drop it, or the server's outbox for it fills and the server drops it
        threading.Thread(target=self._drain, args=(ws,), name='parameter_push_drain', daemon=True).start()

    def _drain(self, ws) -> None:
        try:
            for _ in ws:
                pass
        except LINK_ERRORS:
            pass
        if ws is self._ws:
            self._link_lost.set()
