"""Regression: re-drive a controller from a bag's drive measurements and compare its commands.

The controller (``--package/--executable``, or ``--command``) runs as its own process; each
recorded measurement (raw lockstep topic, else from the status block) is published with /clock
at its stamp and the command of the same ``step`` awaited, the recorded controller's parameter
changes re-applied where they happened. Commands are compared field by field (header
excluded); exit 0 if every step is reproduced exactly, 1 otherwise (docs/bags.md).

    compare_replay bags/run1 --package dtc_controller --executable dtc_controller --json report.json
"""
from __future__ import annotations

import argparse
import bisect
import functools
import json
import os
import sys
import threading
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import rclpy
import yaml
from rcl_interfaces.msg import ParameterEvent
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient
from rclpy.serialization import deserialize_message
from rosgraph_msgs.msg import Clock

from drive_common.processes import NodeProcess
from drive_common.topics import CLOCK, FIRST_ANSWER_RESEND, LOCKSTEP_QOS, PARAMETER_EVENTS
from drive_common.waiting import WaitTimeout, future_result, wait_until
from drive_common.parameter_files import ParameterFileError, read_params_file
from drive_logger import ros_types
from drive_logger.bag_reader import BagReadError, BagReader
from drive_logger.block_topics import block_sources, part_classes, per_sample_messages
from drive_logger.message_definitions import cdr_stamp_ns
from drive_logger.replay_node import clock_cdr, parse_remaps


class CompareError(RuntimeError):
    """The comparison cannot run (bad bag, controller gone, refused change); one line says why."""


class ControllerExited(CompareError):
    """The re-driven controller process ended before the comparison did."""

    def __init__(self, controller: NodeProcess) -> None:
        lines = controller.output().strip().splitlines()
        super().__init__(f'controller {controller.executable} exited (code '
                         f'{controller.process.returncode})' + (f': {lines[-1]}' if lines else ''))


@dataclass
class ComparisonReport:
    steps_replayed: int = 0
    parameter_changes: int = 0                              # recorded changes re-applied
    steps_compared: int = 0
    matching: int = 0
    byte_identical: int = 0
    missing_replies: list = field(default_factory=list)     # steps without an answer
    mismatches: list = field(default_factory=list)          # {step, recorded, replayed} (first 20)
    mismatch_count: int = 0
    first_mismatch_step: int | None = None

    @property
    def identical(self) -> bool:
        return self.steps_compared > 0 and self.mismatch_count == 0 and not self.missing_replies


def _equal(a, b) -> bool:
    """Exact equality of plain values and lists of them; NaN equals NaN (same bits are not required)."""
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(map(_equal, a, b))
    return a == b or (a != a and b != b)


def compare_fields(recorded: dict, replayed: dict) -> bool:
    """Exact equality of plain field values; NaN equals NaN."""
    return recorded.keys() == replayed.keys() and all(_equal(a, replayed[k]) for k, a in recorded.items())


def load_recording(bag: str, measurement_topic: str, command_topic: str, salvage: bool = False,
                   controller_node: str = '/dtc_controller', namespace: str = 'auto'):
    """(measurement type, [(step, stamp_ns, bytes)], command type, {step: bytes}, changes) from a bag.

    Raw lockstep topics if the bag has them, else expanded from the status block
    (:mod:`drive_logger.block_topics`); changes: {index of the first measurement after the
    change: [(name, value), ...]} from the controller node's recorded parameter events.
    """
    reader = BagReader(bag, salvage=salvage, namespace=namespace)   # a namespaced drive: its own
    if reader.namespace and not controller_node.startswith(reader.namespace + '/'):
        controller_node = reader.namespace + controller_node        # events name /NS/node
    infos = reader.topics
    pair = (measurement_topic, command_topic)
    if all(t in infos and infos[t].message_count != 0 for t in pair):
        classes = [ros_types.message_class(infos[t].type) for t in pair]
        stream = reader.messages
    else:
        sources = block_sources(reader)
        for topic in pair:
            if topic not in sources:
                raise CompareError(f'bag {bag!r} has no topic {topic!r} and no block topic carrying it '
                                   f'(topics: {sorted(infos)})')
        classes = [part_classes(sources[t][0])[sources[t][1]] for t in pair]
        stream = functools.partial(per_sample_messages, reader)
    meas_cls, cmd_cls = classes
    measurements, commands, changes, events = [], {}, {}, []
    topics = [measurement_topic, command_topic] + ([PARAMETER_EVENTS] if PARAMETER_EVENTS in infos else [])
    for msg in stream(topics):
        if msg.topic == measurement_topic:
            measurements.append((deserialize_message(msg.data, meas_cls).step, cdr_stamp_ns(msg.data), msg.data))
        elif msg.topic == command_topic:
            commands[deserialize_message(msg.data, cmd_cls).step] = msg.data
        else:
            event = deserialize_message(msg.data, ParameterEvent)
            if event.node == controller_node and event.changed_parameters:
                events.append((msg.log_time, len(measurements), [
                    (p.name, parameter_value_to_python(p.value)) for p in event.changed_parameters]))
    # Sim log times: the controller stamps its event with the last sample it answered (at a hold
    # at T: the one before T), so the change acts from the next sample, after every measurement
    # stamped <= the log time -- counted over the whole bag (a measurement logged at the same
    # time may come later in the stream); wall log times: arrival order.
    stamps = [stamp for _, stamp, _ in measurements]
    sim = reader.log_time_source == 'sim'
    for log_time, arrived_after, change in events:
        index = bisect.bisect_right(stamps, log_time) if sim else arrived_after
        changes.setdefault(index, []).extend(change)
    return meas_cls, measurements, cmd_cls, commands, changes


def replay_and_compare(bag: str, controller: NodeProcess | None, *, measurement_topic: str = '/drive/measurement',
                       command_topic: str = '/drive/gate_command', timeout: float = 30.0,
                       max_steps: int | None = None, salvage: bool = False, context=None,
                       match_timeout: float = 15.0,
                       controller_node: str = '/dtc_controller',
                       namespace: str = 'auto') -> ComparisonReport:
    """Drive the (already started) controller with the bag's measurements; compare its commands."""
    meas_cls, measurements, cmd_cls, recorded, changes = load_recording(
        bag, measurement_topic, command_topic, salvage, controller_node, namespace)
    if max_steps is not None:
        measurements = measurements[:max_steps]
    replies: dict[int, bytes] = {}
    arrived = threading.Condition()

    node = Node('compare_replay', context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)

    def on_command(data: bytes) -> None:
        step = deserialize_message(data, cmd_cls).step
        with arrived:
            replies.setdefault(step, data)
            arrived.notify_all()

    node.create_subscription(cmd_cls, command_topic, on_command, LOCKSTEP_QOS, raw=True)
    meas_pub = node.create_publisher(meas_cls, measurement_topic, LOCKSTEP_QOS)
    clock_pub = node.create_publisher(Clock, CLOCK, 10)
    params = AsyncParameterClient(node, controller_node) if changes else None
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    report = ComparisonReport()
    try:
        def matched() -> bool:
            if controller is not None and not controller.alive():
                raise ControllerExited(controller)
            return meas_pub.get_subscription_count() >= 1 and node.count_publishers(command_topic) >= 1

        wait_until(matched, match_timeout, 0.02,
                   f'the controller to subscribe to {measurement_topic} and publish {command_topic}')
        if params is not None and not params.wait_for_services(timeout_sec=match_timeout):
            raise CompareError(f'{controller_node} parameter services not available')
        for index, (step, stamp, data) in enumerate(measurements):
            if index in changes:
                results = future_result(params.set_parameters([Parameter(n, value=v) for n, v in changes[index]]),
                                        timeout, f'{controller_node} set_parameters').results
                if not all(r.successful for r in results):
                    raise CompareError(f'the controller refused the recorded change {changes[index]}')
                report.parameter_changes += 1
            clock_pub.publish(clock_cdr(stamp))
            meas_pub.publish(data)
            deadline = time.monotonic() + timeout
            resend = FIRST_ANSWER_RESEND if index == 0 else timeout  # the first one may be lost while
            with arrived:                                            # matching: as the plant does
                while not arrived.wait_for(
                        lambda: step in replies or (controller is not None and not controller.alive()),
                        timeout=min(deadline - time.monotonic(), resend)):
                    if time.monotonic() >= deadline:
                        report.missing_replies.append(step)
                        break
                    meas_pub.publish(data)
                else:
                    if step not in replies:
                        raise ControllerExited(controller)
            report.steps_replayed += 1
        for step, _, _ in measurements:
            if step not in recorded or step not in replies:
                continue
            report.steps_compared += 1
            a, b = recorded[step], replies[step]
            report.byte_identical += a == b
            rec_f = ros_types.fields_of(deserialize_message(a, cmd_cls))
            rep_f = ros_types.fields_of(deserialize_message(b, cmd_cls))
            if compare_fields(rec_f, rep_f):
                report.matching += 1
            else:
                report.mismatch_count += 1
                if report.first_mismatch_step is None:
                    report.first_mismatch_step = step
                if len(report.mismatches) < 20:
                    report.mismatches.append({'step': step, 'recorded': rec_f, 'replayed': rep_f})
    finally:
        executor.shutdown(timeout_sec=5.0)
        spinner.join(timeout=5.0)     # a thread left in rcl's wait aborts the interpreter at exit
        node.destroy_node()
    return report


def _parse_param(text: str):
    name, sep, value = text.partition(':=')
    if not sep:
        raise argparse.ArgumentTypeError(f'{text!r} is not name:=value')
    return name, yaml.safe_load(value)


def _run(args) -> ComparisonReport:
    """Start the controller, replay the bag into it, stop it."""
    process = dict(parameters=dict(args.param), remappings=parse_remaps(args.remap), env=dict(os.environ),
                   params_files=[args.params_file] if args.params_file else [])
    if args.command:
        controller = NodeProcess('command', Path(args.command[0]).name, argv=args.command, **process)
    else:
        controller = NodeProcess(args.package, args.executable, **process)
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        return replay_and_compare(args.bag, controller, measurement_topic=args.measurement_topic,
                                  command_topic=args.command_topic, timeout=args.timeout,
                                  max_steps=args.max_steps, salvage=args.salvage, context=context,
                                  controller_node=args.controller_node, namespace=args.namespace)
    finally:
        controller.stop()
        rclpy.try_shutdown(context=context)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog='compare_replay', description=__doc__.split('\n\n')[0])
    ap.add_argument('bag')
    who = ap.add_mutually_exclusive_group(required=True)
    who.add_argument('--executable', help='controller executable (with --package), as ros2 run finds it')
    who.add_argument('--command', nargs='+', help='controller command line (--ros-args are appended)')
    ap.add_argument('--package', default='dtc_controller')
    ap.add_argument('-p', '--param', action='append', default=[], type=_parse_param, help='name:=value (YAML)')
    ap.add_argument('--params-file', help='ROS 2 parameter file of the controller '
                    '(node_name: {ros__parameters: ...} or /**:), passed to it as --params-file')
    ap.add_argument('-r', '--remap', action='append', default=[], help='from:=to remapping for the controller')
    ap.add_argument('--measurement-topic', default='/drive/measurement')
    ap.add_argument('--command-topic', default='/drive/gate_command')
    ap.add_argument('--timeout', type=float, default=30.0,
                    help='s to wait for each reply (reliable delivery may need a retransmission)')
    ap.add_argument('--max-steps', type=int)
    ap.add_argument('--controller-node', default='/dtc_controller',
                    help="whose recorded /parameter_events to re-apply (the replayed node's name)")
    ap.add_argument('--salvage', action='store_true', help='use the intact part of a damaged bag')
    ap.add_argument('--namespace', default='auto',
                    help="the drive's namespace in a bag of several (e.g. /drive1)")
    ap.add_argument('--json', help='write the report here')
    args = ap.parse_args(argv)

    try:
        if args.params_file:
            read_params_file(args.params_file)      # one-line error before starting anything
        report = _run(args)
    except (CompareError, ParameterFileError, BagReadError, WaitTimeout, OSError, ValueError) as exc:
        print(f'[compare_replay] error: {exc}', file=sys.stderr)
        return 2
    summary = asdict(report) | {'identical': report.identical}
    text = json.dumps(summary, indent=2)
    if args.json:
        Path(args.json).write_text(text)
    print(json.dumps({k: v for k, v in summary.items() if k != 'mismatches'}, indent=2))
    if report.mismatches:
        print('first mismatch:', json.dumps(report.mismatches[0]))
    return 0 if report.identical else 1


if __name__ == '__main__':
    sys.exit(main())
