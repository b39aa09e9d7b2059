"""DC link: ideal source, or split capacitors C_upper + C_lower (000 ch. III/IV: C3 = C4 = 270 uF).

Nodes: P (positive rail), M (midpoint), N (negative rail, 0 V). The inverter
draws i_P from P and i_M from M (the four-switch midpoint-phase current,
positive into the motor). Capacitor voltages v_u = V_P - V_M, v_l = V_M.

Modes:
- ``ideal``: stiff source V_dc, stiff midpoint at V_dc/2 (two ideal halves).
- ``split_capacitors``: stiff source across the capacitor string; the sum is
  held, the midpoint drifts: dv_l/dt = -i_M / (C_u + C_l), and the source
  delivers i_P + i_M C_u / (C_u + C_l).
- ``current_fed``: the string is fed by a source current i_s into P (the port
  a boost/rectifier front end drives later):
  C_u dv_u/dt = i_s - i_P, C_l dv_l/dt = i_s - i_P - i_M.
  ``source_current`` is a constant (A) or a callable(time, v_P) -> A set by the
  front end; its energy is counted as DC-source energy here.
All updates take the charge each node drew over a segment (integrals of the
currents, exact for the piecewise-linear circuit). Within a segment the
inverter sees the capacitor voltages predicted at the segment's middle from
the previous segment's average node currents (:meth:`segment_voltages`):
holding the start values instead would act like a series resistance
T/(2C) (0.09 ohm at 50 us, 2 x 270 uF) and leave a first-order error in the
dynamics and the energy balance; with the mid-segment prediction the
residual is second order.
"""
from __future__ import annotations

MODES = ('ideal', 'split_capacitors', 'current_fed')


class DcLink:
    def __init__(self, mode: str, voltage: float, c_upper: float, c_lower: float,
                 initial_midpoint: float = 0.5, source_current=0.0) -> None:
        if mode not in MODES:
            raise ValueError(f'dc_link.mode {mode!r} is not one of {MODES}')
        self.mode = mode
        self.voltage = float(voltage)
        self.c_upper, self.c_lower = float(c_upper), float(c_lower)
        self.v_lower = self.voltage * initial_midpoint
        self.v_upper = self.voltage - self.v_lower
        if mode == 'ideal':
            self.v_lower = self.v_upper = 0.5 * self.voltage
        self.source_current = source_current
        self.energy_source = 0.0
        self.stiff = mode == 'ideal'
        self._i_p = 0.0      # A, average node currents of the last segment
        self._i_m = 0.0
        self._i_s = 0.0

    @classmethod
    def from_params(cls, p: dict) -> 'DcLink':
        return cls(p['dc_link.mode'], p['dc_link.voltage'], p['dc_link.upper_capacitance'],
                   p['dc_link.lower_capacitance'], p['dc_link.initial_midpoint'],
                   p['dc_link.source_current'])

    @property
    def positive(self) -> float:
        """V_P [V]."""
        return self.v_upper + self.v_lower

    def stored_energy(self) -> float:
        """Capacitor energy [J] (0 for the ideal source)."""
        if self.mode == 'ideal':
            return 0.0
        return 0.5 * (self.c_upper * self.v_upper ** 2 + self.c_lower * self.v_lower ** 2)

    def segment_voltages(self, dt: float) -> tuple[float, float]:
        """(V_P, V_M) [V] predicted at the middle of the next segment of length dt [s]."""
        if self.mode == 'ideal':
            return self.v_upper + self.v_lower, self.v_lower
        if self.mode == 'split_capacitors':
            return self.voltage, self.v_lower - 0.5 * dt * self._i_m / (self.c_upper + self.c_lower)
        d_up = 0.5 * dt * (self._i_s - self._i_p) / self.c_upper
        d_lo = 0.5 * dt * (self._i_s - self._i_p - self._i_m) / self.c_lower
        return self.v_upper + d_up + self.v_lower + d_lo, self.v_lower + d_lo

    def draw(self, q_p: float, q_m: float, dt: float, time: float) -> None:
        """The inverter drew charge q_p [C] from P and q_m from M over dt [s] starting at time."""
        mode = self.mode
        self._i_p, self._i_m = q_p / dt, q_m / dt
        if mode == 'ideal':
            self.energy_source += self.positive * q_p + self.v_lower * q_m
        elif mode == 'split_capacitors':
            c_sum = self.c_upper + self.c_lower
            dv = q_m / c_sum
            self.energy_source += self.voltage * (q_p + q_m * self.c_upper / c_sum)
            self.v_lower -= dv
            self.v_upper += dv
        else:
            src = self.source_current
            i_s = src(time, self.positive) if callable(src) else src
            self._i_s = i_s
            q_s = i_s * dt
            v_p0 = self.positive
            self.v_upper += (q_s - q_p) / self.c_upper
            self.v_lower += (q_s - q_p - q_m) / self.c_lower
            self.energy_source += 0.5 * (v_p0 + self.positive) * q_s
