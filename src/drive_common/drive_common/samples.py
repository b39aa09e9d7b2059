"""Plain data exchanged between cores, one field per dtc_msgs message field (no rclpy).

Converted by field name (:mod:`drive_common.lockstep_wire`, :mod:`drive_common.conversions`).
Units as in the messages: SI, electrical angles.
"""
from __future__ import annotations

from dataclasses import dataclass

NAN = float('nan')
TOPOLOGY_FOUR_SWITCH = 4
TOPOLOGY_SIX_SWITCH = 6
ALL_OFF = (False,) * 6


@dataclass(slots=True)
class DriveSample:
    """dtc_msgs/DriveMeasurement: what the DTC controller sees at t_k."""

    step: int                    # lockstep sample index k
    time: float                  # s, sim time t_k
    phase_current: tuple         # A, (i_a, i_b, i_c), NaN where no sensor
    dc_link_voltage: float       # V
    midpoint_voltage: float      # V, lower capacitor voltage
    encoder_count: int           # quadrature counts since start
    encoder_angle: float         # rad, electrical, [0, 2 pi)
    hall_code: int               # bit0 = H_a, bit1 = H_b, bit2 = H_c
    mechanical_speed: float      # rad/s
    hold_after: bool = False     # the last sample before the plant holds sim time


@dataclass(slots=True)
class GateSample:
    """dtc_msgs/GateCommand: switch states SW1..SW6 for the sample `step`."""

    step: int
    topology: int                # 4 or 6
    switch_on: tuple             # 6 bools, SW1..SW6


@dataclass(slots=True)
class PfcSample:
    """dtc_msgs/PfcMeasurement."""

    step: int
    time: float                  # s
    rectified_voltage: float     # V
    inductor_current: float      # A
    output_voltage: float        # V
    hold_after: bool = False     # the last sample before the plant holds sim time


@dataclass(slots=True)
class DutySample:
    """dtc_msgs/DutyCommand."""

    step: int
    duty: float                  # 1, in [0, 1]
    enable: bool
