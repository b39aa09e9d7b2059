"""Sample blocks carry exactly the per-sample messages; the decimator picks the grid samples."""
from __future__ import annotations

import struct
from functools import lru_cache
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from ament_index_python.packages import get_package_share_directory
from rclpy.serialization import deserialize_message, serialize_message

from drive_common.conversions import seconds
from drive_common.samples import DriveSample, GateSample
from drive_common.parameters import ParameterError, schema
from drive_common.telemetry import (DEFAULT_BLOCK_SIZE, MAX_BLOCK_SIZE, TELEMETRY_PARAMETERS, Decimator,
                                    nanoseconds)
from drive_common.telemetry_blocks import (BLOCK_PARTS, HOLD_MARK, LEFT_OUT, BlockPacker, block_columns,
                                           expand, layout, stamp_ns, step_gaps)
from dtc_msgs.msg import DtcStatusBlock, PfcStatusBlock, PlantState, PlantStateBlock

BLOCK_TYPES = (PlantStateBlock, DtcStatusBlock, PfcStatusBlock)
BLOCK_HEADER = {'header': 'std_msgs/Header', 'first_step': 'uint64', 'step_stride': 'uint64',
                'sample_period': 'double', 'count': 'uint32', 'stamp_offset': 'sequence<uint32>'}
NAN_WITH_PAYLOAD = struct.unpack('<d', struct.pack('<Q', 0x7FF8_0000_0000_0123))[0]
NEGATIVE_NAN = struct.unpack('<d', struct.pack('<Q', 0xFFF8_0000_0000_0000))[0]
SPECIAL_FLOATS = (float('nan'), NAN_WITH_PAYLOAD, NEGATIVE_NAN, float('inf'), float('-inf'),
                  -0.0, 5e-324, 1.7976931348623157e308)
INT_RANGES = {'int8': (-128, 128), 'uint8': (0, 256), 'uint32': (0, 2**32), 'int64': (-2**63, 2**63)}
MODES = ('two_phase_six_switch', 'three_phase_dtifc')
TICK = 1e-6   # s, plant base tick of the generated samples (as core.time = step * base_tick)


@pytest.mark.parametrize('block_type', BLOCK_TYPES)
def test_every_per_sample_field_has_its_block_array(block_type):
    """The .msg files cannot drift: one array of the same element type per per-sample field."""
    block_fields = dict(block_type.get_fields_and_field_types())
    for name, kind in BLOCK_HEADER.items():
        assert block_fields.pop(name) == kind, name
    for prefix, msg_type in BLOCK_PARTS[block_type]:
        for field, kind in msg_type.get_fields_and_field_types().items():
            if field in LEFT_OUT:
                assert kind == {'header': 'std_msgs/Header', 'step': 'uint64', HOLD_MARK: 'boolean'}[field]
                continue
            element = kind.split('[')[0]
            want = 'string' if element == 'string' else f'sequence<{element}>'
            assert block_fields.pop(prefix + field, None) == want, \
                f'{block_type.__name__} lacks {want} {prefix + field} for {msg_type.__name__}.{field}'
    assert not block_fields, f'{block_type.__name__} has fields no per-sample message has: {block_fields}'


def _random_value(rng, kind: str):
    element, _, width = kind.partition('[')
    if width:
        values = [_random_value(rng, element) for _ in range(int(width[:-1]))]
        return np.array(values, dtype=np.float64) if element == 'double' else values
    if element == 'double':
        if rng.random() < 0.2:
            return SPECIAL_FLOATS[rng.integers(len(SPECIAL_FLOATS))]
        return float(rng.normal() * 10.0 ** rng.integers(-9, 9))
    if element == 'boolean':
        return bool(rng.random() < 0.5)
    if element == 'string':
        return MODES[0]
    low, high = INT_RANGES[element]
    return int(rng.integers(low, high, dtype=np.int64))


def _samples(block_type, steps, seed=1):
    """Per-sample message tuples (BLOCK_PARTS order) with random fields at the given steps."""
    rng = np.random.default_rng(seed)
    out = []
    for step in steps:
        msgs = []
        for _, msg_type in BLOCK_PARTS[block_type]:
            msg = msg_type()
            msg.step = step
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(nanoseconds(step * TICK), 10**9)
            for field, kind in msg_type.get_fields_and_field_types().items():
                if field not in LEFT_OUT:
                    setattr(msg, field, _random_value(rng, kind))
            msgs.append(msg)
        out.append(tuple(msgs))
    return out


def _pack(block_type, samples, size):
    packer = BlockPacker(block_type, size)
    blocks = [packer.append(stamp_ns(msgs[0].header.stamp), *msgs) for msgs in samples]
    blocks.append(packer.flush())
    assert packer.flush() is None
    return [b for b in blocks if b is not None]


def _roundtrip(block_type, blocks):
    """Blocks through the wire format and back to per-sample messages."""
    out = []
    for block in blocks:
        received = deserialize_message(serialize_message(block), block_type)
        out.extend(expand(received))
    return out


@lru_cache(maxsize=None)
def _rosbags_store():
    """A third-party (rosbags) type store that knows every dtc_msgs message."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    store = get_typestore(Stores.ROS2_JAZZY)
    types = {}
    for path in (Path(get_package_share_directory('dtc_msgs')) / 'msg').glob('*.msg'):
        types.update(get_types_from_msg(path.read_text(), f'dtc_msgs/msg/{path.stem}'))
    store.register(types)
    return store


def _wire_bytes(msg) -> bytes:
    """msg serialized by rclpy, with the CDR alignment padding zeroed.

    rclpy (Fast CDR) leaves padding bytes, e.g. after header.frame_id,
    uninitialised, so two serializations of one message may differ there;
    rosbags decodes the bytes and re-encodes them with zero padding, which
    keeps every value's bits (and shows that a third-party reader decodes it).
    """
    store, name = _rosbags_store(), f'dtc_msgs/msg/{type(msg).__name__}'
    return bytes(store.serialize_cdr(store.deserialize_cdr(serialize_message(msg), name), name))


def _assert_same_bytes(expected, actual):
    assert len(expected) == len(actual)
    for k, (want, got) in enumerate(zip(expected, actual)):
        for w, g in zip(want, got, strict=True):
            assert _wire_bytes(g) == _wire_bytes(w), f'sample {k}: {type(w).__name__}'


@pytest.mark.parametrize('block_type', BLOCK_TYPES)
@pytest.mark.parametrize('size', [1, 7, 40])
def test_pack_serialize_expand_is_byte_exact(block_type, size):
    steps = [1000 + 25 * i for i in range(2 * size + 3)]     # partial last block
    samples = _samples(block_type, steps, seed=size)
    blocks = _pack(block_type, samples, size)
    assert [b.count for b in blocks] == [size] * (len(steps) // size) + (
        [len(steps) % size] if len(steps) % size else [])
    assert all(b.first_step == 1000 + 25 * size * i for i, b in enumerate(blocks))
    _assert_same_bytes(samples, _roundtrip(block_type, blocks))


@pytest.mark.parametrize('block_type', BLOCK_TYPES)
def test_irregular_steps_and_mode_change_close_the_block(block_type):
    """A skipped or repeated step (or a new mode) starts a new block: nothing is reconstructed wrong."""
    steps = [0, 4, 8, 12, 20, 24, 24, 28, 29, 33, 100]
    samples = _samples(block_type, steps, seed=7)
    if block_type is DtcStatusBlock:
        for msgs in samples[7:]:
            msgs[0].mode = MODES[1]
    blocks = _pack(block_type, samples, 40)
    assert len(blocks) > 1 and sum(b.count for b in blocks) == len(steps)
    _assert_same_bytes(samples, _roundtrip(block_type, blocks))


def test_packer_takes_the_core_sample_objects():
    """The controller appends its DriveSample, GateSample and status dataclass, not messages."""
    (status, measurement, command), = _samples(DtcStatusBlock, [50], seed=3)
    fields = [f for f in type(status).get_fields_and_field_types() if f != 'header']
    core_status = SimpleNamespace(**{f: getattr(status, f) for f in fields})
    core_status.switch_on = tuple(status.switch_on)
    drive = DriveSample(50, 50 * TICK, tuple(measurement.phase_current.tolist()),
                        measurement.dc_link_voltage, measurement.midpoint_voltage,
                        measurement.encoder_count, measurement.encoder_angle,
                        measurement.hall_code, measurement.mechanical_speed)
    gate = GateSample(50, command.topology, tuple(command.switch_on))
    packer = BlockPacker(DtcStatusBlock, 40)
    assert packer.append(stamp_ns(status.header.stamp), core_status, drive, gate) is None
    _assert_same_bytes([(status, measurement, command)], _roundtrip(DtcStatusBlock, [packer.flush()]))
    with pytest.raises(ValueError, match='mixes steps'):
        packer.append(0, core_status, drive, GateSample(51, 6, (False,) * 6))


@pytest.mark.parametrize('block_type', BLOCK_TYPES)
def test_block_columns_hold_every_sample(block_type):
    samples = _samples(block_type, [200 + 40 * i for i in range(30)], seed=11)
    block, = _pack(block_type, samples, 40)
    data = serialize_message(block)
    columns = block_columns(deserialize_message(data, block_type))
    third_party = _rosbags_store().deserialize_cdr(data, f'dtc_msgs/msg/{block_type.__name__}')
    assert columns['step'].tolist() == [m[0].step for m in samples]
    assert columns['time'].tolist() == [seconds(m[0].header.stamp) for m in samples]
    for column in layout(block_type).columns:
        values = columns[column.name]
        assert values.shape == ((30, column.width) if column.width > 1 else (30,))
        expected = np.array([getattr(m[column.part], column.source) for m in samples],
                            dtype=values.dtype)
        assert values.tobytes() == expected.tobytes(), column.name   # bit-exact, NaN included
        decoded = np.asarray(getattr(third_party, column.name), dtype=values.dtype)
        assert decoded.tobytes() == values.tobytes(), f'rosbags reads {column.name} differently'


def test_a_block_whose_arrays_disagree_with_its_count_is_refused():
    block, = _pack(PlantStateBlock, _samples(PlantStateBlock, [0, 1, 2]), 40)
    block.count = 4
    with pytest.raises(ValueError, match='phase_current'):
        block_columns(block)
    with pytest.raises(ValueError, match='phase_current'):
        next(expand(block))


@pytest.mark.parametrize('size', [0, -1, MAX_BLOCK_SIZE + 1, 2.5, True])
def test_bad_block_size_is_refused_with_the_reason(size):
    with pytest.raises(ValueError, match='block size'):
        BlockPacker(PlantStateBlock, size)


def test_decimator_keeps_the_first_sample_at_or_after_each_grid_time():
    every_25us = Decimator(1e-3)
    kept = [k for k in range(400) if every_25us.keep(k * 25_000)]
    assert kept == [0, 40, 80, 120, 160, 200, 240, 280, 320, 360]   # every 40th sample
    every_30us = Decimator(1e-3)
    kept = [k * 30 for k in range(200) if every_30us.keep(k * 30_000)]
    assert kept == [0, 1020, 2010, 3000, 4020, 5010]                 # us: first at/after each ms
    assert all(Decimator(0.0).keep(k) for k in range(10))
    restarted = Decimator(1e-3)
    assert [restarted.keep(ns) for ns in (0, 500_000, 1_000_000, 0, 1_000_000)] == \
        [True, False, True, True, True]
    with pytest.raises(ValueError, match='live period'):
        Decimator(-1e-3)



def test_a_value_out_of_range_is_refused_and_loses_no_sample():
    samples = _samples(PlantStateBlock, [0, 10, 20, 40])
    packer = BlockPacker(PlantStateBlock, 40)
    blocks = [packer.append(stamp_ns(m[0].header.stamp), *m) for m in samples[:3]]
    fields = [f for f in PlantState.get_fields_and_field_types() if f != 'header']
    bad = SimpleNamespace(**{f: getattr(samples[3][0], f) for f in fields})
    bad.protection = 300                      # uint8
    for step in (30, 40):   # continuing the open block, and breaking it (a skipped step)
        bad.step = step
        with pytest.raises(OverflowError):
            packer.append(nanoseconds(step * TICK), bad)
        assert packer.pending == 3
    blocks.append(packer.append(stamp_ns(samples[3][0].header.stamp), *samples[3]))
    blocks.append(packer.flush())
    blocks = [b for b in blocks if b is not None]
    assert [b.count for b in blocks] == [3, 1]
    _assert_same_bytes(samples, _roundtrip(PlantStateBlock, blocks))


@pytest.mark.parametrize('value, reason', [(0, 'below the minimum'), (-5, 'below the minimum'),
                                           (MAX_BLOCK_SIZE + 1, 'above the maximum'),
                                           (40.0, 'expected an integer')])
def test_the_block_size_parameter_refuses_bad_values_and_keeps_the_old(value, reason):
    telemetry = schema(TELEMETRY_PARAMETERS)
    current = telemetry.defaults()
    with pytest.raises(ParameterError, match=f'telemetry.block_size: .*{reason}'):
        telemetry.validate_changes(current, {'telemetry.block_size': value})
    assert current['telemetry.block_size'] == DEFAULT_BLOCK_SIZE
    other = DEFAULT_BLOCK_SIZE + 1
    assert telemetry.validate_changes(current, {'telemetry.block_size': other})['telemetry.block_size'] == other
    with pytest.raises(ParameterError, match='telemetry.block_size: can only change while'):
        telemetry.validate_changes(current, {'telemetry.block_size': other}, running=True)
    with pytest.raises(ParameterError, match='telemetry.live_period'):
        telemetry.validate_changes(current, {'telemetry.live_period': -1e-3})


def test_step_gaps_reports_skipped_and_repeated_steps():
    def blocks(*spans):   # (first_step, stride, count)
        return [SimpleNamespace(first_step=f, step_stride=s, count=c) for f, s, c in spans]

    assert step_gaps(blocks((0, 40, 40), (1600, 40, 40), (3200, 0, 1), (3240, 40, 2))) == []
    assert step_gaps(blocks((0, 40, 40), (1640, 40, 40))) == [
        'steps skipped: step 1560 is followed by step 1640 (stride 40)']
    assert step_gaps(blocks((0, 40, 40), (1560, 40, 40))) == [
        'steps repeated: a block starts at step 1560, the previous one ended at step 1560']
    assert step_gaps(blocks((0, 40, 2), (120, 80, 3))) == []       # a period change at step 40
    packed = _pack(PlantStateBlock, _samples(PlantStateBlock, [0, 4, 8, 12, 20, 24, 24, 28]), 40)
    assert step_gaps(packed) == [
        'steps skipped: step 12 is followed by step 20 (stride 4)',
        'steps repeated: a block starts at step 24, the previous one ended at step 24']


def test_a_tick_of_no_whole_number_of_ns_still_fills_blocks():
    """At 30 kHz (33 333.3 ns) the rounded stamps alternate 33 333 / 33 334 ns apart: blocks keep
    every sample's own stamp, so they fill to N and expand to the exact stamps."""
    tick = 1.0 / 30000.0
    packer = BlockPacker(PlantStateBlock, 40)
    blocks, stamps = [], []
    for step in range(120):
        state = PlantState(step=step)
        ns = int(round(step * tick * 1e9))          # what conversions puts in the header
        stamps.append(ns)
        block = packer.append(ns, state)
        if block is not None:
            blocks.append(block)
    assert [b.count for b in blocks] == [40, 40, 40]
    expanded = [msgs[0] for b in blocks for msgs in expand(b)]
    assert [stamp_ns(m.header.stamp) for m in expanded] == stamps
    assert np.array_equal(np.concatenate([block_columns(b)['time'] for b in blocks]),
                          np.array([ns // 1_000_000_000 + (ns % 1_000_000_000) * 1e-9 for ns in stamps]))
