"""Outer speed PI loop producing the torque reference (000 Figs. 2.3 / 4.7), run every N samples.

T* = kp e + integral(ki e dt), e = omega_m* - omega_m [rad/s], clamped to +-torque_limit [N m];
anti-windup by conditional integration and clamping of the integrator.
"""
from __future__ import annotations

from drive_common.compiled import njit


@njit
def speed_pi_update(kp: float, ki: float, every_n: int, sample_period: float, lim: float,
                    integral: float, output: float, count: int, speed_reference: float, speed: float):
    """One call of the PI (module doc; runs on every N-th call): (integral, output, count)."""
    if count == 0:
        err = speed_reference - speed
        dt = every_n * sample_period
        p_term = kp * err
        candidate = integral + ki * err * dt
        unsat = p_term + candidate
        # conditional integration: not further into saturation
        if not ((unsat > lim and err > 0.0) or (unsat < -lim and err < 0.0)):
            integral = max(-lim, min(lim, candidate))
        out = p_term + integral
        output = lim if out > lim else -lim if out < -lim else out
    count += 1
    if count >= every_n:
        count = 0
    return integral, output, count
