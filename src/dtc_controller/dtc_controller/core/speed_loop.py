"""Outer speed PI loop producing the torque reference (000 Figs. 2.3 / 4.7), run every N samples.

T* = kp e + integral(ki e dt), e = omega_m* - omega_m [rad/s], clamped to
+-torque_limit [N m]; anti-windup by conditional integration (the
integrator does not move further into saturation) and clamping of the
integrator itself.
"""
from __future__ import annotations

from drive_common.compiled import interpreted, njit


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
        # conditional integration: do not integrate further into saturation
        if not ((unsat > lim and err > 0.0) or (unsat < -lim and err < 0.0)):
            integral = max(-lim, min(lim, candidate))
        out = p_term + integral
        output = lim if out > lim else -lim if out < -lim else out
    count += 1
    if count >= every_n:
        count = 0
    return integral, output, count


_speed_pi_update = interpreted(speed_pi_update)   # SpeedPI's per-call path (no dispatch cost)


class SpeedPI:
    """PI speed controller; kp [N m s/rad], ki [N m/rad], period = every_n * sample_period [s]."""

    __slots__ = ('kp', 'ki', 'every_n', 'sample_period', 'torque_limit', 'integral', 'output', '_count')

    def __init__(self, kp: float, ki: float, every_n: int, sample_period: float, torque_limit: float) -> None:
        self.kp, self.ki = float(kp), float(ki)
        self.every_n = max(1, int(every_n))
        self.sample_period = float(sample_period)
        self.torque_limit = abs(float(torque_limit))
        self.integral = 0.0
        self.output = 0.0
        self._count = 0

    def set_gains(self, kp: float, ki: float, every_n: int, torque_limit: float) -> None:
        """New gains/period/limit act at the next run; the integral is kept (bumpless)."""
        self.kp, self.ki = float(kp), float(ki)
        self.every_n = max(1, int(every_n))
        self.torque_limit = abs(float(torque_limit))
        self.integral = max(-self.torque_limit, min(self.torque_limit, self.integral))

    def reset(self, integral: float = 0.0) -> None:
        self.integral = float(integral)
        self.output = 0.0
        self._count = 0

    def update(self, speed_reference: float, speed: float) -> float:
        """Call every sample; runs the PI on every N-th call (the first call runs); returns T* [N m]."""
        self.integral, self.output, self._count = _speed_pi_update(
            self.kp, self.ki, self.every_n, self.sample_period, self.torque_limit, self.integral,
            self.output, self._count, speed_reference, speed)
        return self.output
