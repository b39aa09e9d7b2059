"""Sensors sampled at t_k: phase currents, DC and midpoint voltages, encoder, halls, speed.

measured = (1 + gain_error) * true + offset + noise; noise from a numpy Generator seeded by
``sensors.seed``, drawn in a fixed order per sample (currents, DC, midpoint, speed). The encoder
counts 4 * pulses per turn (index at theta_m = 0); its angle is the count's electrical angle plus
``encoder_offset``. Halls: H_x = 1 while the fundamental of k_x is positive. The arithmetic is
the compiled :func:`sense` on a settings array (``SC_*`` slots).
"""
from __future__ import annotations

import math

import numpy as np

from drive_common.compiled import njit
from drive_common.samples import DriveSample

TWO_PI = 2.0 * math.pi
NAN = math.nan
_BLOCK = 4096


# settings array slots (Sensors.cfg)
(SC_GA, SC_GB, SC_GC, SC_OA, SC_OB, SC_OC, SC_THREE, SC_VGAIN, SC_VOFF, SC_CPR, SC_POLES, SC_ENC_OFF,
 SC_I_NOISE, SC_V_NOISE, SC_W_NOISE, SC_SIZE) = range(16)


@njit
def encoder_count(theta_m, counts_per_rev):
    """Quadrature count at theta_m [rad] (index at theta_m = 0)."""
    return math.floor(theta_m * counts_per_rev / TWO_PI)


@njit
def sense(cfg, i0, i1, i2, v_dc, v_mid, theta_m, omega_m, r):
    """(i_a, i_b, i_c, v_dc, v_mid, speed, count, encoder angle) measured (module doc); r holds
    the standard normals of this sample in draw order (only those a nonzero noise uses)."""
    n, j = cfg[SC_I_NOISE], 0
    three = cfg[SC_THREE] != 0.0
    if n > 0.0:
        ia = cfg[SC_GA] * i0 + cfg[SC_OA] + n * r[0]
        ib = cfg[SC_GB] * i1 + cfg[SC_OB] + n * r[1]
        ic = cfg[SC_GC] * i2 + cfg[SC_OC] + n * r[2] if three else NAN
        j = 3 if three else 2
    else:
        ia = cfg[SC_GA] * i0 + cfg[SC_OA]
        ib = cfg[SC_GB] * i1 + cfg[SC_OB]
        ic = cfg[SC_GC] * i2 + cfg[SC_OC] if three else NAN
    vg, vo = cfg[SC_VGAIN], cfg[SC_VOFF]
    vdc = vg * v_dc + vo
    vm = vg * v_mid + vo
    if cfg[SC_V_NOISE] > 0.0:
        vdc += cfg[SC_V_NOISE] * r[j]
        vm += cfg[SC_V_NOISE] * r[j + 1]
        j += 2
    w = omega_m + cfg[SC_W_NOISE] * r[j] if cfg[SC_W_NOISE] > 0.0 else omega_m
    cpr = cfg[SC_CPR]
    count = encoder_count(theta_m, cpr)
    angle = (cfg[SC_POLES] * count * TWO_PI / cpr + cfg[SC_ENC_OFF]) % TWO_PI
    return ia, ib, ic, vdc, vm, w, count, angle


class Sensors:
    def __init__(self, p: dict, pole_pairs: int) -> None:
        self.pole_pairs = pole_pairs
        self.counts_per_rev = 4 * int(p['sensors.encoder_pulses'])
        self._rng = np.random.default_rng(int(p['sensors.seed']))
        self._buf: list[float] = []
        self._pos = 0
        self.cfg = np.zeros(SC_SIZE)
        self._r = np.zeros(6)
        self.configure(p)

    def configure(self, p: dict) -> None:
        """Runtime-changeable error settings."""
        three = int(p['sensors.current_count']) == 3
        i_noise, v_noise = p['sensors.current_noise'], p['sensors.voltage_noise']
        w_noise = p['sensors.speed_noise']
        self.cfg[:] = (*(1.0 + g for g in p['sensors.current_gain_error']), *p['sensors.current_offset'],
                       three, 1.0 + p['sensors.voltage_gain_error'], p['sensors.voltage_offset'],
                       self.counts_per_rev, self.pole_pairs, p['sensors.encoder_offset'], i_noise, v_noise,
                       w_noise)
        self.draws = ((3 if three else 2) * (i_noise > 0.0)
                      + 2 * (v_noise > 0.0) + (w_noise > 0.0))   # normals per sample

    def _randn(self) -> float:
        if self._pos >= len(self._buf):
            self._buf = self._rng.standard_normal(_BLOCK).tolist()
            self._pos = 0
        self._pos += 1
        return self._buf[self._pos - 1]

    def encoder_count(self, theta_m: float) -> int:
        return int(encoder_count(theta_m, self.counts_per_rev))

    def sample(self, step: int, time: float, i, v_dc: float, v_mid: float, theta_m: float,
               theta_m0_count: int, omega_m: float, hall: int) -> DriveSample:
        r = self._r
        for j in range(self.draws):
            r[j] = self._randn()
        ia, ib, ic, vdc, vm, w, count, angle = sense(self.cfg, i[0], i[1], i[2], v_dc, v_mid, theta_m,
                                                     omega_m, r)
        return DriveSample(step, time, (ia, ib, ic), vdc, vm, int(count) - theta_m0_count, angle, hall, w)
