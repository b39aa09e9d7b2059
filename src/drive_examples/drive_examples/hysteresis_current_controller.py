"""Hysteresis phase-current control with six-step commutation of the BLDC of 000.

The classic BLDC drive that 000 ch. I compares DTC with: two phases conduct (120 deg
six-step), the pair chosen from the encoder angle, and a hysteresis comparator keeps the
pair current within +-``current_band`` of I* = T* / k_t (000 App. A: k_t = 2 p K), chopping
+V_dc or -V_dc across the pair. docs/write_your_own_controller.md walks through this file.
"""
import math

from drive_common.compiled import njit
from drive_common.controller_api import GateSample, ParameterSpec, run_controller, schema
from dtc_controller.core.status import DtcStatusSample

# Conducting pair (phase driven +, phase driven -) per 60 deg sector, sector 0 starting at
# theta_e = 30 deg: the phase whose back-EMF constant k_x is on its +K / -K flat top
# (plant convention: k_a = -K on [30, 150] deg, b and c lag by 120 and 240 deg).
PAIRS = ((1, 0), (2, 0), (2, 1), (0, 1), (0, 2), (1, 2))

SCHEMA = schema([
    ParameterSpec('torque_reference', 0.0, 'electromagnetic torque reference T*', 'N*m', -5.0, 5.0),
    ParameterSpec('torque_constant', 0.2292, 'k_t = T / I with two-phase conduction (000 App. A)',
                  'N*m/A', 1e-3, 10.0),
    ParameterSpec('current_band', 0.2, 'hysteresis half-width on the pair current', 'A', 0.0, 10.0),
    ParameterSpec('current_limit', 20.0, 'limit of the current reference |I*|', 'A', 0.0, 24.0),
    ParameterSpec('encoder_offset', 0.0, 'added to the measured electrical encoder angle', 'rad',
                  -6.3, 6.3),
])


@njit
def pair_current_step(encoder_angle, encoder_offset, i_a, i_b, i_c, torque_reference,
                      torque_constant, current_band, current_limit, chop):
    """One sample of the comparator (numba-compiled): (theta_e [rad], sector 0..5 from 30 deg,
    pair current (i_plus - i_minus)/2 [A], chop +-1, held inside I* +- current_band)."""
    theta = (encoder_angle + encoder_offset) % (2.0 * math.pi)
    sector = int(((theta - math.pi / 6.0) % (2.0 * math.pi)) // (math.pi / 3.0)) % 6
    plus, minus = PAIRS[sector]
    currents = (i_a, i_b, i_c)
    reference = max(-current_limit, min(current_limit, torque_reference / torque_constant))
    current = 0.5 * (currents[plus] - currents[minus])
    if current < reference - current_band:
        chop = 1
    elif current > reference + current_band:
        chop = -1
    return theta, sector, current, chop


class HysteresisCurrentCore:
    """ROS-free core: DriveSample of step k -> (GateSample of step k, DtcStatusSample)."""

    SCHEMA = SCHEMA

    def __init__(self, params: dict) -> None:
        self.reconfigure(params)
        self.chop = 1                                   # +1: +V_dc on the pair, -1: -V_dc

    def reconfigure(self, params: dict) -> None:
        self.p = SCHEMA.validate_changes(SCHEMA.defaults(), dict(params))

    def update(self, sample):
        p = self.p
        i_a, i_b, i_c = sample.phase_current
        theta, sector, current, self.chop = pair_current_step(
            sample.encoder_angle, p['encoder_offset'], i_a, i_b, i_c, p['torque_reference'],
            p['torque_constant'], p['current_band'], p['current_limit'], self.chop)
        plus, minus = PAIRS[sector]
        switch_on = [False] * 6                         # SW1/SW2 = a upper/lower, SW3/4 b, SW5/6 c
        switch_on[2 * plus + (0 if self.chop > 0 else 1)] = True
        switch_on[2 * minus + (1 if self.chop > 0 else 0)] = True
        status = DtcStatusSample.partial(
            sample.step, 'hysteresis_current', speed_measured=sample.mechanical_speed,
            torque_reference=p['torque_reference'],
            torque_estimate=p['torque_constant'] * current, q_current=current,
            rotor_angle_estimate=theta, sector=sector + 1, torque_hysteresis=self.chop,
            switch_on=tuple(switch_on))
        return GateSample(sample.step, 6, tuple(switch_on)), status


def main(args=None) -> int:
    return run_controller(HysteresisCurrentCore, 'hysteresis_current_controller', args)


if __name__ == '__main__':
    raise SystemExit(main())
