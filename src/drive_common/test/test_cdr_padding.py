"""serialize_zero_padded: the same values as rclpy's serialization, padding zeroed."""
import random

import pytest
from rclpy.serialization import deserialize_message, serialize_message

from drive_common.cdr_padding import serialize_zero_padded
from drive_common.telemetry_blocks import BLOCK_PARTS, BlockPacker
from drive_testing.block_probe import message_bits


def _block(block_type, size: int, rng: random.Random):
    packer, block, k = BlockPacker(block_type, size), None, 0
    while block is None:
        records = []
        for _, msg_type in BLOCK_PARTS[block_type]:
            msg = msg_type(step=k)
            for name, kind in msg_type.get_fields_and_field_types().items():
                if kind == 'double':
                    setattr(msg, name, rng.uniform(-1e3, 1e3))
                elif kind == 'string':
                    setattr(msg, name, 'mode' * 5)
            records.append(msg)
        block = packer.append(25_000 * k, *records)
        k += 1
    return block


@pytest.mark.parametrize('block_type', list(BLOCK_PARTS))
@pytest.mark.parametrize('size', [1, 2, 3, 7, 40])
def test_values_kept_and_padding_zeroed(block_type, size):
    block = _block(block_type, size, random.Random(size))
    zeroed = serialize_zero_padded(block)
    assert len(zeroed) == len(serialize_message(block))
    assert message_bits(deserialize_message(zeroed, block_type)) == message_bits(block)
    # Garbage in every padding byte (what a reused rmw buffer leaves) is zeroed again.
    dirty = bytearray(zeroed)
    padding = [i for i in range(4, len(dirty)) if dirty[i] == 0]
    for i in padding:
        dirty[i] = 0xAA
        try:
            same = message_bits(deserialize_message(bytes(dirty), block_type)) == message_bits(block)
        except Exception:  # noqa: BLE001 - a length byte: not padding
            same = False
        if not same:
            dirty[i] = 0
    assert any(dirty[i] == 0xAA for i in padding), 'no padding found'
    assert serialize_zero_padded(deserialize_message(bytes(dirty), block_type)) == zeroed


def _rosbags_canonical(data: bytes, type_name: str) -> bytes:
    """rosbags' own CDR (an independent implementation: zero padding, exact length) of data."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    from drive_logger.message_definitions import full_definition
    store = get_typestore(Stores.ROS2_JAZZY)
    if type_name.startswith('dtc_msgs/'):
        store.register(get_types_from_msg(full_definition(type_name), type_name))
    return bytes(store.serialize_cdr(store.deserialize_cdr(data, type_name), type_name))


def _messages():
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from dtc_msgs.msg import DtcStatus, PlantState
    from rcl_interfaces.msg import (FloatingPointRange, Parameter, ParameterDescriptor, ParameterEvent,
                                    ParameterValue)
    empty = ParameterValue()
    full = ParameterValue(type=9, bool_value=True, integer_value=-7, double_value=0.1, string_value='vdc',
                          byte_array_value=[b'\x01', b'\xff'], bool_array_value=[True], integer_array_value=[3],
                          double_array_value=[1.5, -0.0], string_array_value=['a', 'bcd'])
    return [
        ParameterEvent(node='/x'),
        ParameterEvent(node='/dtc_controller', changed_parameters=[
            Parameter(name='torque_reference', value=ParameterValue(type=3, double_value=1.5))]),
        ParameterEvent(node='/plant', new_parameters=[Parameter(name='a', value=full), Parameter(name='b', value=empty)],
                       deleted_parameters=[Parameter(name='c')]),
        empty, full,
        ParameterDescriptor(name='dc_link_voltage', type=3, description='V', read_only=True,
                            floating_point_range=[FloatingPointRange(from_value=0.0, to_value=800.0)]),
        DiagnosticArray(status=[DiagnosticStatus(level=b'\x02', name='plant', message='safe state',
                                                 values=[KeyValue(key='k', value='v')]), DiagnosticStatus()]),
        PlantState(step=11, applied_switch_on=[True] * 6, dc_link_voltage=300.0, safe_state=True),
        DtcStatus(step=3, mode='six_switch_two_phase', sector=-1, switch_on=[False, True] * 3),
    ]


@pytest.mark.parametrize('msg', _messages(), ids=lambda m: type(m).__name__)
def test_canonical_bytes_are_the_cdr_an_independent_implementation_writes(msg):
    """rclpy's bytes carry uninitialised padding and, after an empty sequence of 8-byte
    elements, bytes past the last field; the canonical bytes are exactly rosbags' CDR and
    rclpy reads them back to the same message."""
    from drive_common.cdr_padding import canonicalize
    type_name = f"{type(msg).__module__.split('.')[0]}/msg/{type(msg).__name__}"
    canonical = serialize_zero_padded(msg)
    assert canonical == _rosbags_canonical(canonical, type_name)
    assert message_bits(deserialize_message(canonical, type(msg))) == message_bits(msg)
    assert canonicalize(serialize_message(msg), type(msg)) == canonical
    dirty = bytearray(serialize_message(msg)) + b'\xaa\xbb\xcc\xdd\xee'     # garbage past the fields
    assert canonicalize(bytes(dirty), type(msg)) == canonical
