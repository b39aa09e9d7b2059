"""The ceiling probes: each measurement answered by the responder, round trips counted."""
from __future__ import annotations

import math

import pytest
import rclpy

from drive_testing.ceiling import measure_naive_round_trips, measure_round_trips


@pytest.mark.parametrize('executable, measure', [('raw_responder', measure_round_trips),
                                                 ('naive_responder', measure_naive_round_trips)])
def test_probe_gets_every_step_answered(ros_domain, start_node, executable, measure):
    start_node('drive_testing', executable)
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=ros_domain)
    try:
        rate = measure(context, samples=50)   # returns only once all 2 x 50 steps came back
    finally:
        rclpy.try_shutdown(context=context)
    assert math.isfinite(rate) and rate > 0


def test_naive_probe_without_responder_times_out(ros_domain):
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=ros_domain)
    try:
        with pytest.raises(Exception, match='naive_responder'):
            measure_naive_round_trips(context, samples=5, timeout=0.5)
    finally:
        rclpy.try_shutdown(context=context)
