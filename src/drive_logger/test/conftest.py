"""Helpers shared by the drive_logger tests."""
import math

import pytest


def drive_measurement(step: int):
    """A DriveMeasurement with step-dependent, non-trivial field values."""
    from drive_common.conversions import time_msg
    from dtc_msgs.msg import DriveMeasurement
    msg = DriveMeasurement(step=step, dc_link_voltage=80.0 + 0.001 * step, midpoint_voltage=40.0 - 1e-4 * step,
                           encoder_count=-3 * step, encoder_angle=(0.01 * step) % (2 * math.pi),
                           hall_code=1 + step % 6, mechanical_speed=100.0 + step * 1e-3)
    msg.phase_current = [math.sin(0.1 * step), math.sin(0.1 * step - 2.0), float('nan')]
    msg.header.stamp = time_msg(step * 25e-6)
    return msg


@pytest.fixture
def measurement_factory():
    return drive_measurement
