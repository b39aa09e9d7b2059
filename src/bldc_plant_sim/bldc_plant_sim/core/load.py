"""Load machine on the motor shaft and the mechanical update (changeable at runtime).

Modes: ``torque`` (constant T_L), ``viscous`` (T_L = b w_m), ``dynamometer`` (holds w_m).
J dw/dt = T_e - T_L - B w over a segment: average T_e, implicit trapezoidal rule for the speed
terms, so kinetic-energy change + friction + load work = T_e,avg * w_avg * dt exactly.
"""
from __future__ import annotations

import numpy as np

from .dc_link import array_slot
from .link_kernel import LD_SIZE, LD_MODE, LD_SPEED, LD_TORQUE, LD_VISCOUS

MODES = ('torque', 'viscous', 'dynamometer')


class LoadMachine:
    """Settings in ``x`` (link_kernel LD_* slots), so a change between ticks reaches the kernels."""

    torque = array_slot(LD_TORQUE, 'N m')
    viscous = array_slot(LD_VISCOUS, 'N m s/rad')
    speed = array_slot(LD_SPEED, 'rad/s')

    def __init__(self, mode: str = 'torque', torque: float = 0.0, viscous: float = 0.0,
                 speed: float = 0.0) -> None:
        self.x = np.zeros(LD_SIZE)
        self.configure(mode, torque, viscous, speed)

    @classmethod
    def from_params(cls, p: dict) -> 'LoadMachine':
        return cls(p['load.mode'], p['load.torque'], p['load.viscous'], p['load.speed'])

    def configure(self, mode: str, torque: float, viscous: float, speed: float) -> None:
        if mode not in MODES:
            raise ValueError(f'load.mode {mode!r} is not one of {MODES}')
        self.mode, self.torque, self.viscous, self.speed = mode, float(torque), float(viscous), float(speed)
        self.x[LD_MODE] = MODES.index(mode)
        self.dynamometer = mode == 'dynamometer'

    def load_torque(self, w: float) -> float:
        """T_L at speed w for the torque and viscous modes [N m]."""
        if self.mode == 'torque':
            return self.torque
        if self.mode == 'viscous':
            return self.viscous * w
        return 0.0
