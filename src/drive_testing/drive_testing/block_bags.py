"""Bags of one headless run, written without the ROS graph: per-sample topics, block topics, or both.

For readers' tests: the samples of :func:`drive_bringup.headless.run_headless` (the cores the
nodes wrap), filled and stamped as the nodes fill them and written with
:class:`drive_logger.bag_writer.BagWriter` at sim log times, either every per-sample message
(a recording before blocks) or the blocks as :class:`drive_common.telemetry_blocks.BlockPacker`
packs them, optionally with the decimated live topics.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from unittest import mock

from dtc_msgs.msg import DtcStatusBlock, PfcStatusBlock, PlantStateBlock
from rcl_interfaces.msg import ParameterEvent
from rclpy.parameter import Parameter

from drive_common import topics as names
from drive_common.cdr_padding import canonicalize, serialize_zero_padded
from drive_common.conversions import ReusedMessage
from drive_common.telemetry import DEFAULT_BLOCK_SIZE, DEFAULT_LIVE_PERIOD, Decimator, nanoseconds
from drive_common.telemetry_blocks import BlockPacker, stamp_ns
from drive_logger import qos_yaml
from drive_logger.bag_reader import BagReader
from drive_logger.bag_writer import BagWriter
from drive_logger.block_topics import block_sources, per_sample_messages
from drive_logger.graph_topics import GRAPH_TOPIC_TYPES
from drive_logger.message_definitions import type_definition
from drive_logger.ros_types import message_class, type_name


class _Tap:
    """A controller core that remembers (sample, command, status) of every update."""

    def __init__(self, core) -> None:
        self.core = core
        self.records: list = []

    def update(self, sample):
        command, status = self.core.update(sample)
        self.records.append((sample, command, status))
        return command, status

    def __getattr__(self, name):
        return getattr(self.core, name)


@dataclass
class HeadlessSamples:
    """Every sample of a headless run, in step order, as the nodes would publish them."""

    scenario: object
    states: list = field(default_factory=list)       # (stamp_ns, PlantStateSample)
    dtc: list = field(default_factory=list)          # (stamp_ns, DriveSample, GateSample, DtcStatusSample)
    pfc: list = field(default_factory=list)          # (stamp_ns, PfcSample, DutySample, PfcStatusSample)


def headless_samples(scenario) -> HeadlessSamples:
    """Run the scenario headless and keep every plant state and controller exchange."""
    from drive_bringup import headless
    taps = []
    build = headless.build_controllers

    def tapped(scen):
        cores = [None if core is None else _Tap(core) for core in build(scen)]
        taps.extend(cores)
        return tuple(cores)

    with mock.patch.object(headless, 'build_controllers', tapped):
        result = headless.run_headless(scenario)
    out = HeadlessSamples(scenario)
    trajectory = result.trajectory
    out.states = [(nanoseconds(t), s) for t, s in zip(trajectory.times, trajectory.states)]
    dtc, pfc = taps
    for tap, target in ((dtc, out.dtc), (pfc, out.pfc)):
        if tap is not None:
            target.extend((nanoseconds(s.time), s, c, st) for s, c, st in tap.records)
    return out


PARAMETER_EVENTS = names.PARAMETER_EVENTS.lstrip('/')   # _Bag.write adds the '/'


class _Bag:
    """A BagWriter on sim log times whose topics are registered on first use; it starts with the
    scenario's runtime changes as /parameter_events of their node, logged at the event's sim time
    (the headless run applies them before the sample at that time, as the graph does)."""

    def __init__(self, path: Path, samples: HeadlessSamples) -> None:
        self.writer = BagWriter(path, log_time='sim')
        self._topics: dict = {}
        self._qos = [qos_yaml.profile()]
        for event in samples.scenario.events:
            msg = ParameterEvent(node=f'/{event.node}', changed_parameters=[
                Parameter(name, value=value).to_parameter_msg() for name, value in event.parameters.items()])
            self.write(PARAMETER_EVENTS, msg, nanoseconds(event.time))

    def write(self, topic: str, msg, stamp_ns: int) -> None:
        record = self._topics.get(topic)
        if record is None:
            definition = type_definition(type_name(type(msg)))
            record = self._topics[topic] = self.writer.add_topic('/' + topic, definition, self._qos)
        self.writer.write(record, serialize_zero_padded(msg), stamp_ns, stamp_ns)  # as recorded

    def close(self) -> None:
        self.writer.close()


def _fill(msg_type, data, stamp_ns: int):
    """A new message of msg_type from a core sample, stamped as the nodes stamp it."""
    msg = ReusedMessage(msg_type).fill(data)
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
    return msg


def _per_sample_streams(samples: HeadlessSamples):
    """(stamp_ns, order, topic, message) of every per-sample message of the run."""
    types = {topic: message_class(name) for topic, name in GRAPH_TOPIC_TYPES.items()}
    for stamp, state in samples.states:
        yield stamp, 3, names.PLANT_STATE, _fill(types[names.PLANT_STATE], state, stamp)
    for records, (meas, cmd, status) in (
            (samples.dtc, (names.DRIVE_MEASUREMENT, names.GATE_COMMAND, names.DTC_STATUS)),
            (samples.pfc, (names.PFC_MEASUREMENT, names.DUTY_COMMAND, names.PFC_STATUS))):
        for stamp, sample, command, stat in records:
            yield stamp, 0, meas, _fill(types[meas], sample, stamp)
            yield stamp, 1, cmd, _fill(types[cmd], command, stamp)
            yield stamp, 2, status, _fill(types[status], stat, stamp)


def write_per_sample_bag(samples: HeadlessSamples, path: Path) -> Path:
    """A bag of every per-sample message (the recording before blocks) and the parameter events."""
    bag = _Bag(path, samples)
    for stamp, _, topic, msg in sorted(_per_sample_streams(samples), key=lambda r: (r[0], r[1])):
        bag.write(topic, msg, stamp)
    bag.close()
    return Path(path)


_CARRIED = {names.PLANT_STATE: (), names.DTC_STATUS: (names.DRIVE_MEASUREMENT, names.GATE_COMMAND),
            names.PFC_STATUS: (names.PFC_MEASUREMENT, names.DUTY_COMMAND)}
"""Status topic -> the lockstep topics its block carries (BLOCK_PARTS order after the status)."""


def write_block_bag(samples: HeadlessSamples, path: Path, block_size: int = DEFAULT_BLOCK_SIZE,
                    live_period: float | None = DEFAULT_LIVE_PERIOD, lockstep: bool = False) -> Path:
    """A bag of block topics (+ the live topics decimated to live_period unless None, + the raw
    lockstep topics if asked), as the nodes publish them; blocks logged at their first stamp;
    and the parameter events."""
    packers = {names.PLANT_STATE: (names.PLANT_STATE_BLOCK, BlockPacker(PlantStateBlock, block_size)),
               names.DTC_STATUS: (names.DTC_STATUS_BLOCK, BlockPacker(DtcStatusBlock, block_size)),
               names.PFC_STATUS: (names.PFC_STATUS_BLOCK, BlockPacker(PfcStatusBlock, block_size))}
    decimators = {t: Decimator(live_period) for t in packers} if live_period is not None else {}
    lockstep_topics = {names.DRIVE_MEASUREMENT, names.GATE_COMMAND, names.PFC_MEASUREMENT, names.DUTY_COMMAND}
    bag = _Bag(path, samples)
    sample_parts: dict = {}
    for stamp, _, topic, msg in sorted(_per_sample_streams(samples), key=lambda r: (r[0], r[1])):
        if topic in lockstep_topics:
            sample_parts[topic] = msg
            if lockstep:
                bag.write(topic, msg, stamp)
            continue
        block_topic, packer = packers[topic]
        parts = (msg, *(sample_parts.pop(t) for t in _CARRIED[topic]))
        block = packer.append(stamp, *parts)
        if block is not None:
            bag.write(block_topic, block, stamp_ns(block.header.stamp))
        if topic in decimators and decimators[topic].keep(stamp):
            bag.write(topic, msg, stamp)
    for block_topic, packer in packers.values():
        block = packer.flush()
        if block is not None:
            bag.write(block_topic, block, stamp_ns(block.header.stamp))
    bag.close()
    return Path(path)


def scenario_bags(name: str, duration: float, root: Path, block_size: int = 16):
    """(scenario, {'per_sample': bag, 'blocks': bag}): the first ``duration`` s of a shipped
    scenario run headless and written both ways under root (the fixtures of the bag tests)."""
    from drive_bringup.scenario import find_scenario, load_scenario
    scenario = load_scenario(find_scenario(name)).shortened(duration)
    samples = headless_samples(scenario)
    return scenario, {'per_sample': write_per_sample_bag(samples, root / 'per_sample'),
                      'blocks': write_block_bag(samples, root / 'blocks', block_size=block_size)}


def recorded_samples(bag: Path) -> dict[str, list[bytes]]:
    """{per-sample topic: every sample's canonical CDR} a recorded bag's block topics carry: two bags
    of the same samples compare equal whatever their block boundaries and padding."""
    out: dict[str, list[bytes]] = {}
    reader = BagReader(bag, namespace='auto')    # a namespaced drive's topics named as without
    for msg in per_sample_messages(reader, list(block_sources(reader))):
        out.setdefault(msg.topic, []).append(canonicalize(msg.data, message_class(msg.type)))
    return out
