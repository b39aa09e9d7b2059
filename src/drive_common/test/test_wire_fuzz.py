"""Property-based fuzzing of the lockstep wire decoders (hypothesis).

Whatever bytes arrive on a lockstep topic, a decoder either returns a sample
or raises ValueError naming the message type: the receiving node drops a
malformed message with a warning and never dies of it.
"""
from __future__ import annotations

import struct

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from drive_common.lockstep_wire import ENCAPSULATION, LockstepWire
from drive_common.samples import DriveSample, DutySample, GateSample, PfcSample
from dtc_msgs.msg import DriveMeasurement, DutyCommand, GateCommand, PfcMeasurement

WIRES = {name: LockstepWire(msg, sample) for name, msg, sample in (
    ('DriveMeasurement', DriveMeasurement, DriveSample), ('GateCommand', GateCommand, GateSample),
    ('PfcMeasurement', PfcMeasurement, PfcSample), ('DutyCommand', DutyCommand, DutySample))}
FUZZ = settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])

any_float = st.floats(allow_nan=True, allow_infinity=True, width=64)
SAMPLES = {
    'DriveMeasurement': st.builds(
        DriveSample, st.integers(0, 2 ** 64 - 1), st.just(0.0),
        st.tuples(any_float, any_float, any_float), any_float, any_float,
        st.integers(-2 ** 63, 2 ** 63 - 1), any_float, st.integers(0, 255), any_float),
    'GateCommand': st.builds(GateSample, st.integers(0, 2 ** 64 - 1), st.integers(0, 255),
                             st.tuples(*[st.booleans()] * 6)),
    'PfcMeasurement': st.builds(PfcSample, st.integers(0, 2 ** 64 - 1), st.just(0.0), any_float,
                                any_float, any_float),
    'DutyCommand': st.builds(DutySample, st.integers(0, 2 ** 64 - 1), any_float, st.booleans()),
}


def _decode_or_value_error(wire: LockstepWire, data: bytes):
    """The decoded sample, or None when the decoder refused with ValueError naming the type."""
    try:
        return wire.decode(data)[0]
    except ValueError as exc:
        assert wire.msg_type.__name__ in str(exc)
        return None


def _same(a, b) -> bool:
    """Field-wise equality that takes NaN == NaN (the bits travel unchanged)."""
    def norm(v):
        if isinstance(v, float):
            return struct.pack('<d', v)
        if isinstance(v, tuple):
            return tuple(norm(x) for x in v)
        return v
    return all(norm(getattr(a, f)) == norm(getattr(b, f)) for f in a.__dataclass_fields__
               if f != 'time')


@pytest.mark.parametrize('name', sorted(WIRES))
@FUZZ
@given(data=st.binary(max_size=200))
def test_random_bytes_decode_or_are_refused_with_value_error(name, data):
    _decode_or_value_error(WIRES[name], data)


@pytest.mark.parametrize('name', sorted(WIRES))
@FUZZ
@given(data=st.data())
def test_encoded_samples_round_trip_and_every_mutation_is_decoded_or_refused(name, data):
    """A valid message decodes to its sample bit for bit; truncated, extended, or byte-flipped
    copies of it (a damaged frame_id length among them) decode or raise ValueError."""
    wire = WIRES[name]
    sample = data.draw(SAMPLES[name])
    frame = data.draw(st.text(max_size=12).map(lambda s: s.encode('utf-8', 'replace')))
    encoded = LockstepWire(wire.msg_type, wire.sample_type, frame.decode()).encode(
        sample, data.draw(st.integers(-2 ** 31, 2 ** 31 - 1)), data.draw(st.integers(0, 2 ** 32 - 1)))
    decoded = wire.decode(encoded)[0]
    assert _same(decoded, sample)
    cut = data.draw(st.integers(0, len(encoded)))
    _decode_or_value_error(wire, encoded[:cut])
    _decode_or_value_error(wire, encoded + data.draw(st.binary(max_size=16)))
    position = data.draw(st.integers(0, len(encoded) - 1))
    flipped = bytearray(encoded)
    flipped[position] ^= data.draw(st.integers(1, 255))
    result = _decode_or_value_error(wire, bytes(flipped))
    if result is not None and position >= len(ENCAPSULATION) + 12 + len(frame) + 1:
        # A flip in the fields changes at most the value it lands in, never the message's shape.
        assert type(result) is type(sample)


def test_a_huge_frame_id_length_is_refused_without_allocating():
    wire = WIRES['GateCommand']
    data = ENCAPSULATION + struct.pack('<iII', 0, 0, 0xFFFF_FFF0) + bytes(64)
    with pytest.raises(ValueError, match='GateCommand'):
        wire.decode(data)
