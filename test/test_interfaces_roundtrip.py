"""Every dtc_msgs message crosses a process boundary field-exact.

The test process publishes each message type, filled with seeded random
values in every field (NaN included where a float may be NaN), to a
``message_echo`` node started as ``ros2 run drive_testing message_echo``
would; the echo comes back from the other process and must equal what was
sent, field for field (NaN == NaN by bit pattern).
"""
import array
import math
import random
import struct

import numpy as np
import pytest
from rosidl_parser.definition import (AbstractNestedType, BasicType, NamespacedType)

from drive_testing.harness import send_until_answered, wait_for_subscribers
from drive_common.waiting import wait_until
from drive_testing.message_echo import MESSAGE_TYPES, message_class
from drive_common.topics import LOCKSTEP_QOS

pytestmark = pytest.mark.ros


def _random_value(slot_type, rng: random.Random):
    if isinstance(slot_type, AbstractNestedType):
        size = getattr(slot_type, 'size', None) or rng.randint(0, 4)
        return [_random_value(slot_type.value_type, rng) for _ in range(size)]
    if isinstance(slot_type, BasicType):
        t = slot_type.typename
        if t == 'boolean':
            return rng.random() < 0.5
        if t in ('double', 'float'):
            if rng.random() < 0.1:
                return float('nan')
            value = rng.uniform(-1e3, 1e3)
            return struct.unpack('f', struct.pack('f', value))[0] if t == 'float' else value
        bits = int(''.join(ch for ch in t if ch.isdigit()) or 8)
        if t.startswith('uint') or t in ('octet', 'char'):
            return rng.randrange(0, 2 ** min(bits, 63))
        return rng.randrange(-2 ** (bits - 1), 2 ** (bits - 1) - 1)
    if isinstance(slot_type, NamespacedType):
        return None  # nested message: filled recursively
    return ''.join(rng.choice('abcxyz_ 0123') for _ in range(rng.randint(0, 12)))


def _fill(msg, rng: random.Random):
    for name, slot_type in zip(msg.get_fields_and_field_types(), msg.SLOT_TYPES):
        value = _random_value(slot_type, rng)
        if value is None:
            _fill(getattr(msg, name), rng)
        else:
            setattr(msg, name, value)
    return msg


def _same(a, b) -> bool:
    if hasattr(a, 'get_fields_and_field_types'):
        return type(a) is type(b) and all(
            _same(getattr(a, f), getattr(b, f)) for f in a.get_fields_and_field_types())
    if isinstance(a, (list, tuple, np.ndarray, array.array)):   # array.array: sequence<double> etc.
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, float) or isinstance(b, float):
        fa, fb = float(a), float(b)
        return (math.isnan(fa) and math.isnan(fb)) or struct.pack('d', fa) == struct.pack('d', fb)
    return a == b


def test_same_detects_differences():
    """The comparison used below must be able to fail."""
    cls = message_class('PlantState')
    a = _fill(cls(), random.Random(1))
    b = _fill(cls(), random.Random(1))
    assert _same(a, b)
    b.phase_current[1] = np.nextafter(b.phase_current[1], np.inf)
    assert not _same(a, b)


def test_every_interface_file_is_covered():
    """The echo covers every .msg of dtc_msgs (none can be added and skipped here)."""
    from pathlib import Path
    msg_dir = Path(__file__).resolve().parents[1] / 'src' / 'dtc_msgs' / 'msg'
    assert sorted(p.stem for p in msg_dir.glob('*.msg')) == sorted(MESSAGE_TYPES)


def test_every_message_type_round_trips_between_processes(start_node, ros_session):
    start_node('drive_testing', 'message_echo')
    node = ros_session.node('roundtrip_probe')
    received = {name: [] for name in MESSAGE_TYPES}
    publishers = {}
    for name in MESSAGE_TYPES:
        cls = message_class(name)
        publishers[name] = node.create_publisher(cls, f'echo/in/{name}', LOCKSTEP_QOS)
        node.create_subscription(cls, f'echo/out/{name}', received[name].append, LOCKSTEP_QOS)
    for name in MESSAGE_TYPES:
        wait_for_subscribers(node, f'echo/in/{name}', timeout=20.0)
        wait_until(lambda n=name: node.count_publishers(f'echo/out/{n}') >= 1, 20.0,
                   what=f'echo/out/{name} publisher')

    rng = random.Random(20261122)
    sent = {name: [_fill(message_class(name)(), rng) for _ in range(3)] for name in MESSAGE_TYPES}
    # The graph lists the echo's reader and writer before each has matched this side's
    # writer and reader: a message (or its echo) sent before then is lost. So the ones not
    # yet back are sent again until each has come back, field-exact, at least once.
    missing = {(name, i) for name in MESSAGE_TYPES for i in range(len(sent[name]))}

    def all_back() -> bool:
        missing.difference_update({(name, i) for name, i in missing
                                   if any(_same(sent[name][i], back) for back in received[name])})
        return not missing

    def send_missing() -> None:
        for name, i in sorted(missing):
            publishers[name].publish(sent[name][i])
    send_until_answered(send_missing, all_back, timeout=60.0, every=2.0,
                        what='every message echoed unchanged')
    assert not missing, sorted(missing)
    for name in MESSAGE_TYPES:          # and nothing came back that was not sent
        for back in received[name]:
            assert any(_same(out, back) for out in sent[name]), f'{name} changed on the way: {back}'
