"""The lockstep wire format against rclpy's own CDR serialization, both directions."""
from __future__ import annotations

import math
import random
import struct

import pytest
from rclpy.serialization import deserialize_message, serialize_message

from drive_common.cdr_padding import serialize_zero_padded
from drive_common.conversions import ReusedMessage, from_message, sec_nanosec
from drive_common.lockstep_wire import LockstepWire
from drive_common.samples import DriveSample, DutySample, GateSample, PfcSample
from builtin_interfaces.msg import Time
from dtc_msgs.msg import DriveMeasurement, DtcStatus, DutyCommand, GateCommand, PfcMeasurement

PAIRS = [(DriveMeasurement, DriveSample), (GateCommand, GateSample),
         (PfcMeasurement, PfcSample), (DutyCommand, DutySample)]


def _nan_with_payload(payload: int) -> float:
    return struct.unpack('<d', struct.pack('<Q', 0x7FF8_0000_0000_0000 | payload))[0]


def _random_sample(sample_type: type, rng: random.Random):
    floats = [0.0, -0.0, 1e-300, -7.5, math.inf, -math.inf, _nan_with_payload(0x1234),
              rng.uniform(-1e3, 1e3)]
    values = {
        DriveSample: lambda: DriveSample(
            rng.randrange(2 ** 64), rng.uniform(0, 100), tuple(rng.choice(floats) for _ in range(3)),
            rng.choice(floats), rng.choice(floats), rng.randrange(-2 ** 63, 2 ** 63),
            rng.choice(floats), rng.randrange(256), rng.choice(floats)),
        GateSample: lambda: GateSample(rng.randrange(2 ** 64), rng.choice((4, 6)),
                                       tuple(rng.random() < 0.5 for _ in range(6))),
        PfcSample: lambda: PfcSample(rng.randrange(2 ** 64), rng.uniform(0, 100), rng.choice(floats),
                                     rng.choice(floats), rng.choice(floats)),
        DutySample: lambda: DutySample(rng.randrange(2 ** 64), rng.choice(floats),
                                       rng.random() < 0.5),
    }
    return values[sample_type]()


def _bits(value):
    """Compare floats by their bits (NaN payloads, signed zeros), tuples element-wise."""
    if isinstance(value, tuple):
        return tuple(_bits(v) for v in value)
    if isinstance(value, float):
        return struct.pack('<d', value)
    return value


@pytest.mark.parametrize('msg_type, sample_type', PAIRS)
def test_encode_is_rclpy_serialization_with_zero_padding(msg_type, sample_type):
    rng = random.Random(7)
    wire = LockstepWire(msg_type, sample_type)
    for _ in range(200):
        sample = _random_sample(sample_type, rng)
        sec, nanosec = rng.randrange(2 ** 31), rng.randrange(10 ** 9)
        msg = ReusedMessage(msg_type).fill(sample)
        msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
        assert wire.encode(sample, sec, nanosec) == serialize_zero_padded(msg)


@pytest.mark.parametrize('msg_type, sample_type', PAIRS)
@pytest.mark.parametrize('frame_id', ['', 'a', 'ab', 'abc', 'base_link', 'x' * 13])
def test_decode_reads_what_rclpy_serializes_whatever_the_frame_id(msg_type, sample_type, frame_id):
    rng = random.Random(len(frame_id))
    wire = LockstepWire(msg_type, sample_type)
    for _ in range(50):
        sample = _random_sample(sample_type, rng)
        time_s = rng.uniform(0, 50)
        msg = ReusedMessage(msg_type).fill(sample, time_s)
        msg.header.frame_id = frame_id
        decoded, sec, nanosec = wire.decode(serialize_message(msg))
        assert (sec, nanosec) == (msg.header.stamp.sec, msg.header.stamp.nanosec)
        expected = from_message(msg, sample_type)
        assert {k: _bits(getattr(decoded, k)) for k in expected.__dataclass_fields__} == \
            {k: _bits(getattr(expected, k)) for k in expected.__dataclass_fields__}


def test_round_trip_keeps_every_bit_and_rclpy_reads_it():
    wire = LockstepWire(DriveMeasurement, DriveSample)
    nan = _nan_with_payload(0xBEEF)
    sample = DriveSample(42, 0.5, (nan, -0.0, 3.25), 56.5, 28.25, -9, 1.0, 5, -30.0)
    sec, nanosec = sec_nanosec(sample.time)
    data = wire.encode(sample, sec, nanosec)
    back, _, _ = wire.decode(data)
    assert _bits(back.phase_current) == _bits(sample.phase_current)
    msg = deserialize_message(data, DriveMeasurement)
    assert msg.step == 42 and msg.encoder_count == -9 and msg.hall_code == 5
    assert struct.pack('<d', msg.phase_current[0]) == struct.pack('<d', nan)


def test_malformed_messages_are_named():
    wire = LockstepWire(GateCommand, GateSample)
    good = wire.encode(GateSample(3, 6, (True,) * 6), 0, 0)
    with pytest.raises(ValueError, match='GateCommand: not a little-endian CDR message'):
        wire.decode(b'\x00\x00\x00\x00' + good[4:])
    with pytest.raises(ValueError, match='GateCommand: 20 bytes, the fields need'):
        wire.decode(good[:20])
    with pytest.raises(ValueError, match='switch_on: 5 values, expected 6'):
        wire.encode(GateSample(3, 6, (True,) * 5), 0, 0)


def test_only_fixed_size_messages_with_a_header_qualify():
    with pytest.raises(TypeError, match=r'DtcStatus\.mode: string has no fixed CDR size'):
        LockstepWire(DtcStatus, DriveSample)
    with pytest.raises(TypeError, match='Time: the first field must be std_msgs/Header'):
        LockstepWire(Time, DriveSample)
    with pytest.raises(TypeError, match='no GateCommand field'):
        LockstepWire(GateCommand, DriveSample)
