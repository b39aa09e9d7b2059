"""Sensors sampled at t_k: phase currents, DC and midpoint voltages, encoder, halls, speed.

measured = (1 + gain_error) * true + offset + noise, with noise drawn from a
numpy Generator seeded by ``sensors.seed`` (blocks of standard normals, drawn
in a fixed order per sample: currents, DC voltage, midpoint voltage, speed),
so a run is reproducible sample for sample. The quadrature encoder counts
4 * pulses per mechanical turn (index aligned with theta_m = 0); its angle is
the electrical angle of the count, plus ``encoder_offset``. Halls read the
back-EMF shape's hall table (H_x = 1 while the fundamental of k_x is positive).
"""
from __future__ import annotations

import math

import numpy as np

from drive_common.samples import DriveSample

TWO_PI = 2.0 * math.pi
NAN = math.nan
_BLOCK = 4096


class Sensors:
    def __init__(self, p: dict, pole_pairs: int) -> None:
        self.pole_pairs = pole_pairs
        self.counts_per_rev = 4 * int(p['sensors.encoder_pulses'])
        self._rng = np.random.default_rng(int(p['sensors.seed']))
        self._buf: list[float] = []
        self._pos = 0
        self.configure(p)

    def configure(self, p: dict) -> None:
        """Runtime-changeable error settings."""
        self.current_count = int(p['sensors.current_count'])
        self.i_offset = tuple(p['sensors.current_offset'])
        self.i_gain = tuple(1.0 + g for g in p['sensors.current_gain_error'])
        self.i_noise = p['sensors.current_noise']
        self.v_offset = p['sensors.voltage_offset']
        self.v_gain = 1.0 + p['sensors.voltage_gain_error']
        self.v_noise = p['sensors.voltage_noise']
        self.w_noise = p['sensors.speed_noise']
        self.encoder_offset = p['sensors.encoder_offset']

    def _randn(self) -> float:
        if self._pos >= len(self._buf):
            self._buf = self._rng.standard_normal(_BLOCK).tolist()
            self._pos = 0
        self._pos += 1
        return self._buf[self._pos - 1]

    def encoder_count(self, theta_m: float) -> int:
        return math.floor(theta_m * self.counts_per_rev / TWO_PI)

    def sample(self, step: int, time: float, i, v_dc: float, v_mid: float, theta_m: float,
               theta_m0_count: int, omega_m: float, hall: int) -> DriveSample:
        g, o = self.i_gain, self.i_offset
        n = self.i_noise
        if n > 0.0:
            ia = g[0] * i[0] + o[0] + n * self._randn()
            ib = g[1] * i[1] + o[1] + n * self._randn()
            ic = g[2] * i[2] + o[2] + n * self._randn() if self.current_count == 3 else NAN
        else:
            ia = g[0] * i[0] + o[0]
            ib = g[1] * i[1] + o[1]
            ic = g[2] * i[2] + o[2] if self.current_count == 3 else NAN
        vg, vo = self.v_gain, self.v_offset
        vdc = vg * v_dc + vo
        vm = vg * v_mid + vo
        if self.v_noise > 0.0:
            vdc += self.v_noise * self._randn()
            vm += self.v_noise * self._randn()
        w = omega_m + self.w_noise * self._randn() if self.w_noise > 0.0 else omega_m
        count = self.encoder_count(theta_m)
        angle = (self.pole_pairs * count * TWO_PI / self.counts_per_rev + self.encoder_offset) % TWO_PI
        return DriveSample(step, time, (ia, ib, ic), vdc, vm, count - theta_m0_count, angle, hall, w)
