"""Message <-> sample conversion: fresh and reused messages carry exactly the sample."""
import math

import numpy as np
from rclpy.serialization import serialize_message

from dtc_msgs.msg import DriveMeasurement, GateCommand

from drive_common.conversions import ReusedMessage, from_message, seconds, time_msg
from drive_common.samples import DriveSample, GateSample


def _sample(k: int) -> DriveSample:
    return DriveSample(step=k, time=k * 25e-6, phase_current=(1.0 + k, -2.5, float('nan')),
                       dc_link_voltage=np.float64(300.0 + k), midpoint_voltage=150.0,
                       encoder_count=np.int64(-7 * k), encoder_angle=0.25 * k, hall_code=5,
                       mechanical_speed=12.5)


def test_round_trip_keeps_every_field_and_the_stamp():
    sample = _sample(3)
    back = from_message(ReusedMessage(DriveMeasurement).fill(sample, sample.time), DriveSample)
    assert back.step == 3 and back.hall_code == 5 and back.encoder_count == -21
    assert back.phase_current[:2] == (4.0, -2.5) and math.isnan(back.phase_current[2])
    assert type(back.phase_current[0]) is float      # plain Python, not numpy
    assert back.dc_link_voltage == 303.0 and back.time == sample.time


def test_reused_message_serializes_like_a_fresh_one_after_refills():
    reused = ReusedMessage(DriveMeasurement)
    for k in (1, 2, 40000):
        msg = reused.fill(_sample(k), _sample(k).time)
        fresh = ReusedMessage(DriveMeasurement).fill(_sample(k), _sample(k).time)
        assert serialize_message(msg) == serialize_message(fresh)
    assert msg is reused.msg and msg.step == 40000


def test_reused_message_takes_a_given_stamp():
    stamp = time_msg(0.123456789)
    msg = ReusedMessage(GateCommand).fill(GateSample(step=9, topology=6, switch_on=(True,) * 6),
                                          stamp=stamp)
    assert seconds(msg.header.stamp) == seconds(stamp) and list(msg.switch_on) == [True] * 6
    assert from_message(msg, GateSample) == GateSample(9, 6, (True,) * 6)


def test_time_msg_rounds_to_the_nanosecond():
    stamp = time_msg(1.9999999996)
    assert (stamp.sec, stamp.nanosec) == (2, 0)
    assert (time_msg(0.5e-9 * 3).nanosec) == 2
