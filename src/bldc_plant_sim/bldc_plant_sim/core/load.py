"""Load machine on the motor shaft and the mechanical update (changeable at runtime).

Modes: ``torque`` (constant T_L against positive rotation), ``viscous``
(T_L = b w_m) and ``dynamometer`` (holds w_m at its speed setting; the torque
it applies is whatever that takes). Mechanics J dw/dt = T_e - T_L - B w are
advanced over a segment with the average electromagnetic torque of the
segment and the implicit trapezoidal rule for the speed-proportional terms,
so kinetic-energy change + friction + load work = T_e,avg * w_avg * dt exactly.
"""
from __future__ import annotations

MODES = ('torque', 'viscous', 'dynamometer')


class LoadMachine:
    def __init__(self, mode: str = 'torque', torque: float = 0.0, viscous: float = 0.0,
                 speed: float = 0.0) -> None:
        self.configure(mode, torque, viscous, speed)

    @classmethod
    def from_params(cls, p: dict) -> 'LoadMachine':
        return cls(p['load.mode'], p['load.torque'], p['load.viscous'], p['load.speed'])

    def configure(self, mode: str, torque: float, viscous: float, speed: float) -> None:
        if mode not in MODES:
            raise ValueError(f'load.mode {mode!r} is not one of {MODES}')
        self.mode, self.torque, self.viscous, self.speed = mode, float(torque), float(viscous), float(speed)
        self.dynamometer = mode == 'dynamometer'

    def load_torque(self, w: float) -> float:
        """T_L at speed w for the torque and viscous modes [N m]."""
        if self.mode == 'torque':
            return self.torque
        if self.mode == 'viscous':
            return self.viscous * w
        return 0.0

    def step(self, inertia: float, friction: float, w0: float, te: float, dt: float):
        """Advance the shaft over dt with average T_e = te.

        Returns (w1, w_avg, t_load, friction_energy, load_energy).
        """
        if self.dynamometer:
            w1 = self.speed
            w_avg = 0.5 * (w0 + w1)
            t_load = te - friction * w_avg - inertia * (w1 - w0) / dt
        else:
            b_load = self.viscous if self.mode == 'viscous' else 0.0
            t_const = self.torque if self.mode == 'torque' else 0.0
            b = friction + b_load
            w1 = (inertia * w0 + dt * (te - t_const - 0.5 * b * w0)) / (inertia + 0.5 * b * dt)
            w_avg = 0.5 * (w0 + w1)
            t_load = t_const + b_load * w_avg
        return w1, w_avg, t_load, friction * w_avg * w_avg * dt, t_load * w_avg * dt
