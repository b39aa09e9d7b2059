"""live_view node: serve the running graph to the Foxglove app over the Foxglove WebSocket protocol.

Built on ``foxglove-sdk`` (docs/live_view.md): each chosen topic as a channel with its
``ros2msg`` schema and the CDR bytes as received, decimated by sim time; ``/clock`` as the
server time; the graph's parameters through each node's parameter services; its own health on
/diagnostics. A viewer never blocks the graph: best-effort subscriptions, a bounded queue to
the send thread (full: the oldest frame is dropped and counted), the SDK's bounded outbox.
Parameters: :data:`LIVE_VIEW_SCHEMA`; bad parameters end the node with exit code 2.
"""
from __future__ import annotations

import sys
import threading

import foxglove
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import ParameterEvent
from rclpy.node import Node
from rclpy.parameter import Parameter as RosParameter, parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from foxglove import Parameter as FoxgloveParameter, ParameterType, StatusLevel
from foxglove.websocket import Capability
from rosgraph_msgs.msg import Clock

from drive_common import topics as t
from drive_common.lockstep_io import DirectReceiver
from drive_common.node_main import run_node
from drive_common.parameters import ParameterError, ParameterSpec, schema
from drive_common.ros_parameters import SchemaParameters
from drive_common.telemetry import Decimator
from drive_common.waiting import future_result
from drive_logger import graph_topics, ros_types
from drive_logger.core import live_view as core
from drive_logger.message_definitions import DefinitionNotFoundError, cdr_stamp_ns, type_definition
from drive_logger.parameter_push import ParameterPush

DEFAULT_TOPICS = [t.PLANT_STATE, t.DTC_STATUS, t.PFC_STATUS, t.DIAGNOSTICS]
DIAGNOSTICS_DEPTH = 64     # rare and each one matters (a fault): not thinned by the queue depth


class LiveViewConfigError(RuntimeError):
    """Bad live_view configuration (nothing served)."""


def _positive(*names: str):
    def check(values) -> None:
        for name in names:
            if not values[name] > 0.0:
                raise ParameterError(f'{name}: {values[name]} s must be > 0')
    return check


LIVE_VIEW_SCHEMA = schema([
    ParameterSpec('topics', list(DEFAULT_TOPICS), 'served topics: name or name:pkg/msg/Type'),
    ParameterSpec('decimation_period', 0.0, 'per topic, at most one message per this much sim time (0 = all)', 's'),
    ParameterSpec('topic_periods', ['/diagnostics=0'], 'per-topic name=seconds overrides of decimation_period'),
    ParameterSpec('time_period', 0.001, 'server-time broadcasts from /clock, at most one per this much sim time', 's'),
    ParameterSpec('host', '127.0.0.1', 'address the WebSocket server listens on'),
    ParameterSpec('port', 8765, 'WebSocket port (0 = any free port; the log says which)', min_value=0, max_value=65535),
    ParameterSpec('qos_depth', 1, 'depth of the best-effort subscriptions to the served topics', min_value=1),
    ParameterSpec('queue_depth', 256, 'frames between the receive and the send thread', min_value=1),
    ParameterSpec('message_backlog_size', 1024, "the SDK's outbox per client", min_value=1),
    ParameterSpec('parameter_timeout', 5.0, 'per ROS parameter service call', 's'),
    ParameterSpec('diagnostics_period', 1.0, 'period of /diagnostics (wall time)', 's'),
    ParameterSpec('batch_period', 0.005, 'rest after a wake-up that took messages (wall time)', 's',
                  min_value=0.0, max_value=0.1),
], _positive('parameter_timeout', 'diagnostics_period'), read_only=True)
"""The live view's parameters (all read-only, set at start); see the module docstring."""


def _plain(value):
    """A value the app sent, arrays as lists of Python numbers."""
    return ros_types.plain(value) if isinstance(value, (list, tuple)) else value


class _Stream:
    """One served topic: its Foxglove channel and decimator."""

    __slots__ = ('name', 'channel', 'decimator', 'forwarded')

    def __init__(self, name, channel, decimator):
        self.name, self.channel, self.decimator, self.forwarded = name, channel, decimator, 0


class LiveViewNode(Node):
    """See the module docstring."""

    def __init__(self, **kwargs) -> None:
        super().__init__('live_view', **kwargs)
        p = self.parameters = SchemaParameters(self, LIVE_VIEW_SCHEMA)
        self.parameter_timeout = float(p['parameter_timeout'])
        self.batch_period = float(p['batch_period'])
        try:
            default_period = core.check_period(float(p['decimation_period']))
            self._time_decimator = Decimator(core.check_period(float(p['time_period'])))
            overrides = self._topic_periods(p['topic_periods'] or [])
        except ValueError as exc:
            raise LiveViewConfigError(str(exc)) from exc
        self.outbox = core.Outbox(int(p['queue_depth']))
        self.sim_time_ns = 0
        self.viewers: dict[int, set[int]] = {}         # client id -> subscribed channel ids
        self._viewers_lock = threading.Lock()
        wanted = self._resolve(p['topics'] or [])
        self.context_fg = foxglove.Context()
        self.streams: list[_Stream] = []
        self._io = rclpy.create_node('live_view_stream', context=self.context,
                                     namespace=self.get_namespace(), start_parameter_services=False)
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=int(p['qos_depth']),
                         reliability=ReliabilityPolicy.BEST_EFFORT, durability=DurabilityPolicy.VOLATILE)
        diagnostics_qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=DIAGNOSTICS_DEPTH,
                                     reliability=ReliabilityPolicy.BEST_EFFORT, durability=DurabilityPolicy.VOLATILE)
        self._stream_subscriptions = []
        for name, (type_name, definition) in wanted.items():
            channel = foxglove.Channel(
                name, message_encoding='cdr', context=self.context_fg,
                schema=foxglove.Schema(name=type_name, encoding='ros2msg', data=definition.text.encode()))
            stream = _Stream(name, channel, Decimator(overrides.get(name, default_period)))
            self.streams.append(stream)
            self._stream_subscriptions.append(self._io.create_subscription(
                ros_types.message_class(type_name), name, self._receiver_for(stream),
                diagnostics_qos if name == t.DIAGNOSTICS else qos, raw=True))
        self._stream_subscriptions.append(self._io.create_subscription(Clock, t.CLOCK, self._on_clock, qos, raw=True))

        self.param_clients: dict[str, AsyncParameterClient] = {}
        self.create_subscription(ParameterEvent, t.PARAMETER_EVENTS, self._on_parameter_event, 100)
        self._diag_pub = self.create_publisher(DiagnosticArray, t.DIAGNOSTICS, 10)
        self.create_timer(float(p['diagnostics_period']), self.publish_diagnostics)
        # before the server: a viewer may set parameters as soon as it is up
        self.push = ParameterPush(str(p['host']), on_error=lambda reason: self._status(reason, 'Error'))
        try:
            self.server = foxglove.start_server(
                name='drive live view', host=str(p['host']), port=int(p['port']),
                capabilities=[Capability.Parameters, Capability.Time], server_listener=self,
                supported_encodings=['cdr'], context=self.context_fg,
                message_backlog_size=int(p['message_backlog_size']))
        except Exception as exc:   # the SDK raises its own error type for a port in use
            raise LiveViewConfigError(f'cannot serve on {p["host"]}:{p["port"]}: {exc}') from exc
        try:
            self.push.open(self.server.port)
        except ConnectionError as exc:
            self.server.stop()
            raise LiveViewConfigError(str(exc)) from exc
        self.get_logger().info(
            f'live view ready: ws://{p["host"]}:{self.server.port} serving {len(self.streams)} topic(s) '
            f'{[s.name for s in self.streams]}')

    def _topic_periods(self, specs) -> dict[str, float]:
        out = {}
        for spec in specs:
            name, sep, seconds = spec.partition('=')
            if not sep or not name.strip():
                raise ValueError(f'topic_periods entry {spec!r} is not name=seconds')
            try:
                out[self.resolve_topic_name(name.strip())] = core.check_period(float(seconds))
            except ValueError as exc:
                raise ValueError(f'topic_periods entry {spec!r}: {exc}') from exc
        return out

    def _resolve(self, specs) -> dict:
        out = {}
        for spec in specs:
            try:
                name, type_name = graph_topics.parse_topic_spec(spec)
            except ValueError as exc:
                raise LiveViewConfigError(f'topics: {exc}') from exc
            if type_name is None:
                raise LiveViewConfigError(
                    f'topics: unknown type of {name!r}; give it as name:pkg/msg/Type')
            try:
                ros_types.message_class(type_name)
                out[self.resolve_topic_name(name)] = (type_name, type_definition(type_name))
            except (ros_types.UnknownTypeError, DefinitionNotFoundError, ValueError) as exc:
                raise LiveViewConfigError(f'topic {name!r}: {exc}') from exc
        return out

    def _receiver_for(self, stream: _Stream):
        outbox, decimator = self.outbox, stream.decimator

        def on_message(data: bytes) -> None:
            try:
                stamp = cdr_stamp_ns(data)
            except ValueError:
                return
            if decimator.keep(stamp):
                outbox.put((stream, data, stamp))
        return on_message

    def _on_clock(self, data: bytes) -> None:
        stamp = cdr_stamp_ns(data)
        self.sim_time_ns = stamp
        if self._time_decimator.keep(stamp):
            self.outbox.put((None, None, stamp))

    def receive_loop(self, stop: threading.Event) -> None:
        """Take what the subscriptions hold, forward what is due; never waits on a viewer."""
        receiver = DirectReceiver(self.context, self._stream_subscriptions)
        while not stop.is_set():
            if receiver.poll(0.1) and self.batch_period > 0.0:
                stop.wait(self.batch_period)

    def send_loop(self, stop: threading.Event) -> None:
        while not stop.is_set():
            for stream, data, stamp in self.outbox.take_all(0.1):
                if stream is None:
                    self.server.broadcast_time(stamp)
                else:
                    stream.channel.log(data, log_time=stamp)
                    stream.forwarded += 1

    # the Foxglove ServerListener callbacks, called from the SDK's threads
    def on_subscribe(self, client, channel) -> None:
        with self._viewers_lock:
            self.viewers.setdefault(client.id, set()).add(channel.id)

    def on_unsubscribe(self, client, channel) -> None:
        with self._viewers_lock:
            channels = self.viewers.get(client.id, set())
            channels.discard(channel.id)
            if not channels:
                self.viewers.pop(client.id, None)

    def on_get_parameters(self, client, param_names, request_id=None):
        try:
            return self._fg_parameters(self.get_ros_parameters(list(param_names)))
        except Exception as exc:   # the SDK thread must get an answer, not an exception
            self._status(f'get parameters failed: {exc}', 'Error')
            return []

    def on_set_parameters(self, client, parameters, request_id=None):
        if self.push.is_push(request_id):
            return list(parameters)            # our own push: the SDK sends these to their subscribers
        try:
            values = self.set_ros_parameters({p.name: _plain(p.get_value()) for p in parameters})
            return self._fg_parameters(values)
        except Exception as exc:
            self._status(f'set parameters failed: {exc}', 'Error')
            return []

    def on_parameters_subscribe(self, param_names) -> None:
        """Send the current values first, so a subscriber starts from the truth (from a thread:
        the SDK calls this with its own state locked, and the ROS calls may take a while)."""
        def push() -> None:
            try:
                # through ParameterPush, never server.publish_parameter_values (see that module)
                self.push.publish(self.get_ros_parameters(list(param_names)))
            except Exception as exc:
                self._status(f'parameter subscription: {exc}', 'Error')
        threading.Thread(target=push, daemon=True).start()

    def on_parameters_unsubscribe(self, param_names) -> None:
        return None

    def _client(self, node: str) -> AsyncParameterClient | None:
        client = self.param_clients.get(node)
        if client is None:
            client = self.param_clients[node] = AsyncParameterClient(self, node)
        if not client.wait_for_services(timeout_sec=min(1.0, self.parameter_timeout)):
            return None
        return client

    def graph_nodes(self) -> list[str]:
        """Fully qualified names of the other nodes that serve parameters."""
        own = {self.get_fully_qualified_name(), self._io.get_fully_qualified_name()}
        names = []
        for name, namespace in self.get_node_names_and_namespaces():
            full = namespace.rstrip('/') + '/' + name
            if full in own or name.startswith('_'):
                continue
            services = {s for s, _ in self.get_service_names_and_types_by_node(name, namespace)}
            if f'{full}/get_parameters' in services:
                names.append(full)
        return sorted(set(names))

    def get_ros_parameters(self, full_names: list[str]) -> dict[str, object]:
        """'/node.param' -> value, from the nodes' get_parameters services (all of them if empty)."""
        wanted = core.by_node(full_names) if full_names else {n: None for n in self.graph_nodes()}
        values = {}
        for node, names in wanted.items():
            client = self._client(node)
            if client is None:
                continue
            try:
                if names is None:
                    # a node that does not answer within 1 s is left out (not everyone waits for it)
                    names = list(future_result(client.list_parameters(), min(1.0, self.parameter_timeout),
                                               f'{node} list_parameters').result.names)
                response = future_result(client.get_parameters(names), self.parameter_timeout,
                                         f'{node} get_parameters')
            except TimeoutError as exc:
                if not full_names:             # listing everything: leave out a node that does not answer
                    self.get_logger().info(f'{exc}; its parameters are left out')   # (the recorder: no executor)
                    continue
                raise
            for name, value in zip(names, response.values):
                if value.type != 0:                    # PARAMETER_NOT_SET: not declared
                    values[core.parameter_name(node, name)] = ros_types.plain(parameter_value_to_python(value))
        return values

    def set_ros_parameters(self, changes: dict[str, object]) -> dict[str, object]:
        """Set through each node's set_parameters service; return the values now in force (a refusal's
        reason goes to the app as a status message and to the log)."""
        current = self.get_ros_parameters(list(changes))
        for node, names in core.by_node(changes).items():
            client = self._client(node)
            if client is None:
                self._status(f'{node} serves no parameters: {", ".join(names)} not set', 'Error')
                continue
            params = [RosParameter(name, value=core.coerce(changes[core.parameter_name(node, name)],
                                                           current.get(core.parameter_name(node, name))))
                      for name in names]
            response = future_result(client.set_parameters(params), self.parameter_timeout, f'{node} set_parameters')
            for param, result in zip(params, response.results):
                if not result.successful:
                    self._status(f'{node} refused {param.name} = {param.value!r}: {result.reason}', 'Warning')
        return self.get_ros_parameters(list(changes))

    def _on_parameter_event(self, event: ParameterEvent) -> None:
        if event.node == self.get_fully_qualified_name():
            return
        values = {core.parameter_name(event.node, p.name): ros_types.plain(parameter_value_to_python(p.value))
                  for p in (*event.new_parameters, *event.changed_parameters)}
        self.push.publish(values)

    @staticmethod
    def _fg_parameters(values: dict[str, object]) -> list:
        return [FoxgloveParameter(name, value=value,
                                  type=getattr(ParameterType, hint) if (hint := core.type_hint(value)) else None)
                for name, value in values.items()]

    def _status(self, message: str, level: str) -> None:
        self.get_logger().warning(message)
        self.server.publish_status(message, getattr(StatusLevel, level))

    def publish_diagnostics(self) -> None:
        with self._viewers_lock:
            viewers = len(self.viewers)
        dropped = self.outbox.dropped
        values = [('viewers_subscribed', viewers), ('dropped_frames', dropped)]
        values += [(f'forwarded {s.name}', s.forwarded) for s in self.streams]
        status = DiagnosticStatus(
            level=DiagnosticStatus.WARN if dropped else DiagnosticStatus.OK,
            name='live_view', hardware_id='foxglove websocket',
            message=f'{viewers} viewer(s) subscribed, {dropped} frame(s) dropped',
            values=[KeyValue(key=k, value=str(v)) for k, v in values])
        msg = DiagnosticArray(status=[status])
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(self.sim_time_ns, 1_000_000_000)
        self._diag_pub.publish(msg)

    def stop(self) -> None:
        """End serving (run_node calls it once serve() has joined its threads; the executor still
        runs, and a parameter event that comes now is not pushed)."""
        self.outbox.close()
        self.push.close()
        self.server.stop()
        self._io.destroy_node()


def serve(node: LiveViewNode, stop: threading.Event) -> None:
    """The receive and send threads of a running live view, until stop is set."""
    threads = [threading.Thread(target=node.receive_loop, args=(stop,), daemon=True),
               threading.Thread(target=node.send_loop, args=(stop,), daemon=True)]
    for thread in threads:
        thread.start()
    stop.wait()
    for thread in threads:
        thread.join(timeout=2.0)


def main(args=None) -> int:
    return run_node(LiveViewNode, args, work=serve, errors=(LiveViewConfigError,))


if __name__ == '__main__':
    sys.exit(main())
