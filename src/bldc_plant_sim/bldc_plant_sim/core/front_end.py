"""Switching-level boost PFC front end of 000 ch. III (Fig. 3.1), no rclpy.

60 Hz grid -> optional EMI filter (C1, L1 + L2, C2) -> diode bridge -> boost
inductor L -> boost switch, or boost diode into the split capacitor string kept by
:class:`~.dc_link.DcLink` in ``current_fed`` mode; the switch held off is a plain
diode-bridge rectifier. States i_f, v_c, i_L; conduction modes ``COND``,
``OVERLAP`` and ``BLOCK``. Pieces between events (PWM edges, zero crossings,
located DCM / overlap / over-current events) are integrated with the implicit
midpoint rule in closed form, so the energy balance closes to round-off. PWM
carrier locked to sim time (``triangle`` or ``sawtooth``); protections open the
switch cycle by cycle or latched (000 3.3).

Circuit, equations, events, PWM, protections and the PlantCore wiring:
docs/models.md "Boost PFC front end".
"""
from __future__ import annotations

import math

from drive_common.compiled import njit

TWO_PI = 2.0 * math.pi
SQRT2 = math.sqrt(2.0)

BLOCK, COND, OVERLAP = 0, 1, 2
MODE_NAMES = ('block', 'conduct', 'overlap')

BOOST_OVER_CURRENT = 2   # = dtc_msgs/PlantState PROTECTION_BOOST_OVER_CURRENT
BOOST_OVER_VOLTAGE = 4   # = dtc_msgs/PlantState PROTECTION_BOOST_OVER_VOLTAGE

CARRIERS = ('triangle', 'sawtooth')

_MAX_PIECES_PER_ADVANCE = 100_000
_EVENT_LOG_MAX = 10_000

@njit
def carrier(t: float, f_pwm: float, duty: float, triangle: bool):
    """PWM carrier locked to sim time: (switch on, time of the next carrier edge after t, period index).

    Triangle: on for [0, d T/2] and [T - d T/2, T]; sawtooth: on for [0, d T) (module doc).
    """
    x = t * f_pwm
    tol = max(1e-9, 8.0 * abs(x) * 2.3e-16)
    k = math.floor(x + tol)
    u = x - k
    if u < 0.0:
        u = 0.0
    if triangle:
        e1 = 0.5 * duty
        e2 = 1.0 - e1
        if u < e1 - tol:
            on, nxt = True, e1
        elif u < e2 - tol:
            on, nxt = False, e2
        else:
            on, nxt = duty > 0.0, 1.0
    elif u < duty - tol:
        on, nxt = True, duty
    else:
        on, nxt = False, 1.0
    return on, (k + nxt) / f_pwm, k


@njit
def substep_coefficients(h: float, L_f2: float, R_f: float, C_f2: float, L2: float, R: float):
    """Implicit-midpoint coefficients of a filter sub-step of length h [s]: (al, g1, be, ga, g3, k_c, k_b).

    al = 2 L_f / h, be = 2 C_2 / h, ga = 2 L / h; g1, g3 the branch conductances; k_c, k_b the
    inverse node sums of the COND and BLOCK eliminations (module doc "Integration").
    """
    al = L_f2 / h
    g1 = 1.0 / (al + R_f)
    be = C_f2 / h
    ga = L2 / h
    g3 = 1.0 / (ga + R)
    return al, g1, be, ga, g3, 1.0 / (be + g1 + g3), 1.0 / (be + g1)


@njit
def filter_substep(mode: int, s: int, gate: bool, lim: float, V_b: float, u: float, vg: float,
                   al: float, g1: float, be: float, ga: float, g3: float, k_c: float, k_b: float,
                   i_f0: float, v_c0: float, i_L0: float):
    """One implicit-midpoint sub-step in a conduction mode: mid values (a, b, c) of (i_f, v_c, i_L),
    end values (v_c1, i_L1) and whether an event (module doc: zero, overlap, over-current, start,
    overlap end) lies inside it."""
    A1 = vg + al * i_f0
    if mode == COND:      # L_f di_f/dt = v_g - v_c - R_f i_f, C2 dv_c/dt = i_f - s i_L, L di_L/dt = ...
        A3 = ga * i_L0 - V_b - u
        b = (be * v_c0 + A1 * g1 - s * A3 * g3) * k_c
        a = (A1 - b) * g1
        c = (A3 + s * b) * g3
        i_L1 = 2.0 * c - i_L0
        v_c1 = 2.0 * b - v_c0
        event = i_L1 < 0.0 or (s * v_c1 < 0.0 < s * v_c0) or (gate and 0.0 < lim < i_L1 and i_L0 < lim)
    elif mode == BLOCK:   # i_L = 0: the filter alone
        b = (be * v_c0 + A1 * g1) * k_b
        a = (A1 - b) * g1
        c = 0.0
        v_c1 = 2.0 * b - v_c0
        i_L1 = 0.0
        event = abs(v_c1) > V_b + u
    else:                 # OVERLAP: v_c clamped at 0
        a = A1 * g1
        b = 0.0
        c = (ga * i_L0 - V_b - u) * g3
        i_L1 = 2.0 * c - i_L0
        v_c1 = 0.0
        event = i_L1 <= abs(2.0 * a - i_f0) or (gate and 0.0 < lim < i_L1 and i_L0 < lim)
    return a, b, c, v_c1, i_L1, event


@njit
def filter_substeps(mode: int, s: int, gate: bool, lim: float, V_b: float, u: float, R: float,
                    R_f: float, L_f2: float, C_f2: float, L2: float, vp: float, w: float, ph: float,
                    h_max: float, t: float, span: float, i_f0: float, v_c0: float, i_L0: float):
    """Sub-steps of at most h_max over span [s] from t in one mode, stopping before an event.

    Returns (t, i_f, v_c, i_L, h, event, q, e_grid, e_line, e_ind, e_sq): the time and state
    reached, the last sub-step length, whether it holds an event (not taken), the link charge
    and the ledger integrals (v_g i_f, i_f^2, i_L, i_L^2; midpoint rule: closes exactly).
    """
    q = e_grid = e_line = e_ind = e_sq = 0.0
    t_end = t + span
    eps = 1e-9 * span
    h_c = -1.0
    al = g1 = be = ga = g3 = k_c = k_b = 0.0
    while True:
        h = t_end - t
        if h > h_max:
            h = h_max if h - h_max > eps else h
        if h != h_c:                       # coefficients of this sub-step length
            h_c = h
            al, g1, be, ga, g3, k_c, k_b = substep_coefficients(h, L_f2, R_f, C_f2, L2, R)
        vg = vp * math.sin(w * (t + 0.5 * h) + ph)
        a, b, c, v_c1, i_L1, event = filter_substep(mode, s, gate, lim, V_b, u, vg, al, g1, be, ga,
                                                    g3, k_c, k_b, i_f0, v_c0, i_L0)
        if event:
            return t, i_f0, v_c0, i_L0, h, True, q, e_grid, e_line, e_ind, e_sq
        e_grid += h * vg * a
        e_line += h * a * a
        if mode != BLOCK:
            e_ind += h * c
            e_sq += h * c * c
            if not gate:
                q += h * c
        i_f0, v_c0, i_L0 = 2.0 * a - i_f0, v_c1, i_L1
        t += h
        if t_end - t <= eps:
            return t_end, i_f0, v_c0, i_L0, h, False, q, e_grid, e_line, e_ind, e_sq


@njit
def midpoint_values(t: float, h: float, mode: int, s: int, R: float, u: float, vp: float, w: float,
                    ph: float, L_f: float, R_f: float, C_f: float, L: float, V_b: float, i_f: float,
                    v_c: float, i_L: float):
    """Implicit-midpoint mid values (i_f, v_c, i_L) and v_g(t + h/2) of a piece of length h [s]
    from state (i_f, v_c, i_L) in one mode (module doc's mode equations, eliminated in closed form)."""
    vg = vp * math.sin(w * (t + 0.5 * h) + ph)
    al = 2.0 * L_f / h
    g1 = 1.0 / (al + R_f)
    A1 = vg + al * i_f
    if mode == COND:
        be = 2.0 * C_f / h
        g3 = 1.0 / (2.0 * L / h + R)
        A3 = 2.0 * L / h * i_L - V_b - u
        b = (be * v_c + A1 * g1 - s * A3 * g3) / (be + g1 + g3)
        return (A1 - b) * g1, b, (A3 + s * b) * g3, vg
    if mode == BLOCK:
        be = 2.0 * C_f / h
        b = (be * v_c + A1 * g1) / (be + g1)
        return (A1 - b) * g1, b, 0.0, vg
    g3 = 1.0 / (2.0 * L / h + R)     # OVERLAP: v_c clamped at 0
    return A1 * g1, 0.0, (2.0 * L / h * i_L - V_b - u) * g3, vg


# Event kinds of event_quantity (each quantity is > 0 before its event).
EV_OVERLAP, EV_ZERO, EV_OVER_CURRENT, EV_OVERLAP_END_POS, EV_OVERLAP_END_NEG = 1, 2, 3, 4, 5
EV_START_POS, EV_START_NEG, EV_PLAIN_START = 6, 7, 8


@njit
def event_quantity(kind: int, x: float, t: float, mode: int, s: int, R: float, u: float, lim: float,
                   vp: float, w: float, ph: float, L_f: float, R_f: float, C_f: float, L: float,
                   V_b: float, i_f0: float, v_c0: float, i_L0: float) -> float:
    """Event quantity after a piece of length x [s] from t (> 0 before the event): i_L (zero),
    s v_c (overlap), lim - i_L, i_L -+ i_f (overlap end), the bridge drive (start; plain: no filter)."""
    if kind == EV_PLAIN_START:
        return V_b + u - abs(vp * math.sin(w * (t + x) + ph))
    a, b, c, _ = midpoint_values(t, x, mode, s, R, u, vp, w, ph, L_f, R_f, C_f, L, V_b, i_f0, v_c0, i_L0)
    thr = V_b + u
    if kind == EV_ZERO:
        return 2.0 * c - i_L0
    if kind == EV_OVERLAP:
        return s * (2.0 * b - v_c0)
    if kind == EV_OVER_CURRENT:
        return lim - (2.0 * c - i_L0)
    if kind == EV_OVERLAP_END_POS:
        return (2.0 * c - i_L0) - (2.0 * a - i_f0)
    if kind == EV_OVERLAP_END_NEG:
        return (2.0 * c - i_L0) + (2.0 * a - i_f0)
    if kind == EV_START_POS:
        return thr - (2.0 * b - v_c0)
    return thr + (2.0 * b - v_c0)


@njit
def locate_event(kind: int, h: float, t: float, mode: int, s: int, R: float, u: float, lim: float,
                 vp: float, w: float, ph: float, L_f: float, R_f: float, C_f: float, L: float,
                 V_b: float, i_f0: float, v_c0: float, i_L0: float) -> float:
    """Smallest x in (0, h] with event_quantity(kind, x) <= 0, given > 0 at 0+ and <= 0 at h
    (bracketed Illinois iteration, module doc "Integration")."""
    args = (t, mode, s, R, u, lim, vp, w, ph, L_f, R_f, C_f, L, V_b, i_f0, v_c0, i_L0)
    lo, hi = 0.0, h
    f_lo = event_quantity(kind, h * 1e-9, *args)
    if f_lo <= 0.0:
        return h * 1e-9
    f_hi = event_quantity(kind, h, *args)
    side = 0
    for _ in range(60):
        x = hi - f_hi * (hi - lo) / (f_hi - f_lo) if f_hi != f_lo else 0.5 * (lo + hi)
        if not lo < x < hi:
            x = 0.5 * (lo + hi)
        fx = event_quantity(kind, x, *args)
        if fx <= 0.0:
            hi, f_hi = x, fx
            if side == -1:
                f_lo *= 0.5
            side = -1
        else:
            lo, f_lo = x, fx
            if side == 1:
                f_hi *= 0.5
            side = 1
        if hi - lo <= 1e-12 * h or f_hi == 0.0:
            break
    return hi


# Plant-schema names -> FrontEnd keyword (see FrontEnd.from_params and the report).
PARAMETER_NAMES = {
    'front_end.line_voltage': 'line_voltage',
    'front_end.line_frequency': 'line_frequency',
    'front_end.line_phase': 'line_phase',
    'front_end.line_resistance': 'line_resistance',
    'front_end.line_inductance': 'line_inductance',
    'front_end.filter.enabled': 'filter_enabled',
    'front_end.filter.inductance': 'filter_inductance',
    'front_end.filter.capacitance': 'filter_capacitance',
    'front_end.filter.resistance': 'filter_resistance',
    'front_end.boost.inductance': 'inductance',
    'front_end.boost.resistance': 'inductor_resistance',
    'front_end.bridge.diode_drop': 'bridge_diode_drop',
    'front_end.boost.switch_resistance': 'switch_resistance',
    'front_end.boost.diode_drop': 'diode_drop',
    'front_end.pwm_frequency': 'pwm_frequency',
    'front_end.pwm_carrier': 'pwm_carrier',
    'front_end.over_current_limit': 'over_current_limit',
    'front_end.over_voltage_limit': 'over_voltage_limit',
    'front_end.protection_latched': 'protection_latched',
    'front_end.max_step': 'max_step',
}


class FrontEndLedger:
    """Cumulative front-end energies since start [J]."""

    __slots__ = ('grid', 'delivered', 'line_resistance', 'inductor_resistance', 'bridge',
                 'switch', 'diode', 'numerical')

    def __init__(self) -> None:
        self.grid = 0.0                 # delivered by the grid (incl. C1's reactive exchange)
        self.delivered = 0.0            # into the DC link: v_o(predicted) * boost-diode charge
        self.line_resistance = 0.0      # supply + EMI-filter series resistances
        self.inductor_resistance = 0.0  # R_L i_L^2
        self.bridge = 0.0               # 2 V_f i_L
        self.switch = 0.0               # R_on i_L^2
        self.diode = 0.0                # V_fd i_L
        self.numerical = 0.0            # energy of the snaps onto event surfaces (~1e-20 J)

    @property
    def losses(self) -> float:
        return (self.line_resistance + self.inductor_resistance + self.bridge + self.switch
                + self.diode + self.numerical)


class FrontEnd:
    """Grid + EMI filter + diode bridge + boost stage, integrated by :meth:`advance`."""

    def __init__(self, *, line_voltage: float = 25.4, line_frequency: float = 60.0,
                 line_phase: float = 0.0, line_resistance: float = 0.0,
                 line_inductance: float = 0.0, filter_enabled: bool = True,
                 filter_inductance: float = 10e-6, filter_capacitance: float = 1e-6,
                 filter_resistance: float = 0.05, inductance: float = 1e-3,
                 inductor_resistance: float = 0.1, bridge_diode_drop: float = 0.8,
                 switch_resistance: float = 0.07, diode_drop: float = 1.0,
                 pwm_frequency: float = 80e3, pwm_carrier: str = 'triangle',
                 over_current_limit: float = 8.0, over_voltage_limit: float = 140.0,
                 protection_latched: bool = False, max_step: float = 1e-6,
                 time: float = 0.0) -> None:
        self.filter_enabled = bool(filter_enabled)
        self.configure(line_voltage=line_voltage, line_frequency=line_frequency,
                       line_phase=line_phase, line_resistance=line_resistance,
                       line_inductance=line_inductance, filter_inductance=filter_inductance,
                       filter_capacitance=filter_capacitance, filter_resistance=filter_resistance,
                       inductance=inductance, inductor_resistance=inductor_resistance,
                       bridge_diode_drop=bridge_diode_drop, switch_resistance=switch_resistance,
                       diode_drop=diode_drop, pwm_frequency=pwm_frequency, pwm_carrier=pwm_carrier,
                       over_current_limit=over_current_limit,
                       over_voltage_limit=over_voltage_limit,
                       protection_latched=protection_latched, max_step=max_step)
        # State.
        self.time = float(time)
        self.i_f = 0.0
        self.v_c = self.grid_voltage(self.time) if self.filter_enabled else 0.0
        self.i_L = 0.0
        self.s = 1                     # bridge polarity of the conducting diagonal
        self.mode = BLOCK
        self.gate = False              # boost switch state at self.time
        self.duty = 0.0
        self.enable = False
        self.over_current = False
        self.over_voltage = False
        self._oc_period = -1           # PWM period index of the last over-current trip
        self.events: list[tuple[float, str]] = []   # (time, what): protections always,
        self.log_switching_events = False           # zero/start/overlap only when True
        self.last_event = (math.nan, '')
        self.on_protection = None   # callable(kind, time, text) per trip ('over_current' / 'over_voltage')
        self.event_counts = {'zero': 0, 'start': 0, 'overlap': 0, 'overlap_end': 0,
                             'over_current': 0, 'over_voltage': 0}
        self.energy = FrontEndLedger()

    # ------------------------------------------------------------------ parameters
    @classmethod
    def from_params(cls, p: dict, time: float = 0.0) -> 'FrontEnd':
        """Build from a plant parameter snapshot (names in PARAMETER_NAMES)."""
        kw = {k: p[n] for n, k in PARAMETER_NAMES.items() if n in p}
        return cls(time=time, **kw)

    def reconfigure(self, p: dict) -> None:
        """Runtime update from a plant snapshot; the state is kept.

        ``front_end.filter.enabled`` cannot change in place (rebuild the front
        end; the lead's PlantCore moves the stored-energy baseline then).
        """
        kw = {k: p[n] for n, k in PARAMETER_NAMES.items() if n in p and k != 'filter_enabled'}
        self.configure(**kw)

    def configure(self, **kw) -> None:
        for k, v in kw.items():
            setattr(self, k, v)
        if self.pwm_carrier not in CARRIERS:
            raise ValueError(f'pwm_carrier {self.pwm_carrier!r} is not one of {CARRIERS}')
        self.v_peak = SQRT2 * float(self.line_voltage)
        self.omega = TWO_PI * float(self.line_frequency)
        self.R_s = float(self.line_resistance)
        self.R_L = float(self.inductor_resistance)
        if self.filter_enabled:     # supply impedance in series with L1 + L2
            self.L = float(self.inductance)
            self.L_f = 2.0 * float(self.filter_inductance) + float(self.line_inductance)
            self.R_f = 2.0 * float(self.filter_resistance) + self.R_s
            self._R_plain = self.R_L
        else:                       # supply impedance moved to the DC side of the bridge
            self.L = float(self.inductance) + float(self.line_inductance)
            self.L_f = 0.0
            self.R_f = 0.0
            self._R_plain = self.R_L + self.R_s
        self.C_f = float(self.filter_capacitance)           # C2 (bridge side)
        self.C_1 = float(self.filter_capacitance)           # C1 (grid side)
        self.V_b = 2.0 * float(self.bridge_diode_drop)      # two bridge diodes in the path
        self.R_on = float(self.switch_resistance)
        self.V_d = float(self.diode_drop)
        self.f_pwm = float(self.pwm_frequency)
        self._triangle = self.pwm_carrier == 'triangle'
        self.h_max = float(self.max_step) if self.filter_enabled else math.inf

    # ------------------------------------------------------------------ commands
    def set_duty(self, duty: float, enable: bool) -> None:
        """Latch the duty command (held until the next call)."""
        self.duty = min(1.0, max(0.0, float(duty)))
        self.enable = bool(enable)

    def reset_protection(self) -> None:
        """Clear latched flags (they re-trip at once if the condition still holds)."""
        self.over_current = self.over_voltage = False

    @property
    def protection(self) -> int:
        """PlantState PROTECTION_BOOST_* bits currently active."""
        return (BOOST_OVER_CURRENT if self.over_current else 0) | (
            BOOST_OVER_VOLTAGE if self.over_voltage else 0)

    @property
    def switch_enabled(self) -> bool:
        """Boost switching enabled after protections (PlantState.boost_switch_enabled)."""
        return self.enable and not (self.over_current or self.over_voltage)

    @property
    def applied_duty(self) -> float:
        """PlantState.boost_duty: the duty applied (0 while held off)."""
        return self.duty if self.switch_enabled else 0.0

    # ------------------------------------------------------------------ outputs
    def grid_voltage(self, t: float) -> float:
        return self.v_peak * math.sin(self.omega * t + self.line_phase)

    def _grid_slope(self, t: float) -> float:
        return self.v_peak * self.omega * math.cos(self.omega * t + self.line_phase)

    @property
    def bridge_input_voltage(self) -> float:
        """V, C2 voltage (filter) or the grid voltage (no filter) at self.time."""
        return self.v_c if self.filter_enabled else self.grid_voltage(self.time)

    @property
    def rectified_voltage(self) -> float:
        """V, |bridge input| = the rectified line voltage the PFC senses (PfcMeasurement)."""
        return abs(self.bridge_input_voltage)

    @property
    def grid_current(self) -> float:
        """A, line current at self.time (filter: i_f + C1 dv_g/dt; else the bridge input current)."""
        if self.filter_enabled:
            return self.i_f + self.C_1 * self._grid_slope(self.time)
        if self.mode == COND:
            return self.s * self.i_L
        return 0.0

    @property
    def inductor_current(self) -> float:
        return self.i_L

    def stored_energy(self) -> float:
        """J: boost inductor, filter inductors, C2 and C1 (C1 at the grid voltage now)."""
        e = 0.5 * self.L * self.i_L * self.i_L
        if self.filter_enabled:
            vg = self.grid_voltage(self.time)
            e += 0.5 * (self.L_f * self.i_f * self.i_f + self.C_f * self.v_c * self.v_c
                        + self.C_1 * vg * vg)
        return e

    def measurement(self) -> tuple[float, float]:
        """(rectified_voltage, inductor_current) for PfcMeasurement at self.time."""
        return self.rectified_voltage, self.i_L

    def balance_error(self, stored_initial: float) -> float:
        """grid - (stored - stored_initial) - losses - delivered [J] (round-off only)."""
        en = self.energy
        return en.grid - (self.stored_energy() - stored_initial) - en.losses - en.delivered

    # ------------------------------------------------------------------ PWM carrier
    def _carrier(self, t: float) -> tuple[bool, float, int]:
        """(carrier says on, time of the next carrier edge after t, PWM period index at t)."""
        return carrier(t, self.f_pwm, self.duty, self._triangle)

    # ------------------------------------------------------------------ integration
    def advance(self, t: float, dt: float, v_out: float) -> float:
        """Integrate [t, t + dt] with the DC-link (positive rail) voltage held at v_out [V].

        Returns the charge [C] delivered into the positive rail (boost-diode
        current integral); events located inside are appended to self.events.
        Pass v_out = the link voltage predicted at the segment middle.
        """
        self.time = t
        en = self.energy
        if self.filter_enabled:
            vg0 = self.grid_voltage(t)
        ov = self.over_voltage_limit
        if ov > 0.0 and v_out > ov and not self.over_voltage:
            self.over_voltage = True
            self.event_counts['over_voltage'] += 1
            self._protection(t, 'over_voltage', f'boost over-voltage: v_o = {v_out:.3f} V above '
                             f'{ov:g} V: switch opened')
        q_total = 0.0
        t_end = t + dt
        eps = min(1e-9 / self.f_pwm, 1e-6 * dt)   # edges this close to the end merge into it
        pieces = 0
        while t_end - self.time > eps:
            pieces += 1
            if pieces > _MAX_PIECES_PER_ADVANCE:
                raise RuntimeError(f'front end: too many pieces at t = {self.time:.9f} s (chattering)')
            tn = self.time
            on, t_edge, k = self._carrier(tn)
            if not self.protection_latched and (self.over_current or self.over_voltage):
                if self.over_current and k > self._oc_period and self.i_L <= self.over_current_limit:
                    self.over_current = False
                if self.over_voltage and v_out <= ov:
                    self.over_voltage = False
            if self.i_L > self.over_current_limit > 0.0 and not self.over_current:
                self._trip_over_current()    # e.g. rectifier inrush with the switch already off
            gate = on and self.enable and self.duty > 0.0 and not (self.over_current
                                                                   or self.over_voltage)
            self.gate = gate
            t_stop = t_end if t_edge > t_end - eps else t_edge
            if self.filter_enabled:
                q_total += self._piece_filter(tn, t_stop - tn, gate, v_out)
            else:
                # Split at the grid zero crossing (instantaneous commutation).
                ph = self.omega * tn + self.line_phase
                t_zc = ((math.floor(ph / math.pi + 1e-12) + 1.0) * math.pi - self.line_phase) / self.omega
                if t_zc < t_stop - eps:
                    t_stop = t_zc
                q_total += self._piece_plain(tn, t_stop - tn, gate, v_out)
        self.time = t_end
        if self.filter_enabled:
            vg1 = self.grid_voltage(t_end)
            en.grid += 0.5 * self.C_1 * (vg1 * vg1 - vg0 * vg0)   # C1: exact
        return q_total

    # ---- no filter: one state i_L, bridge input = grid voltage
    def _piece_plain(self, t: float, h: float, gate: bool, v_out: float) -> float:
        """One piece of at most h [s] from t; advances self.time; returns the link charge.

        Midpoint rule on L di_L/dt = |v_g| - 2 V_f - R i_L - u (module doc, no filter): mid current
        c = (g i0 + |v_g| - V_b - u) / (g + R), g = 2 L / h.
        """
        vg = self.grid_voltage(t + 0.5 * h)
        u_off = 0.0 if gate else v_out + self.V_d
        R = self._R_plain + (self.R_on if gate else 0.0)
        i0 = self.i_L
        if i0 == 0.0 and self._plain_blocked(t, h, vg, u_off):
            return 0.0
        g = 2.0 * self.L / h
        c = (g * i0 + abs(vg) - self.V_b - u_off) / (g + R)       # mid-piece current
        if i0 == 0.0 and c <= 0.0:        # forward bias too brief to build up current
            self.mode = BLOCK
            self.time = t + h
            return 0.0
        self.mode = COND
        self.s = 1 if vg >= 0.0 else -1
        i1 = 2.0 * c - i0
        h, event = self._plain_event(t, h, gate, i0, i1, R, u_off)
        if event is not None:
            vg = self.grid_voltage(t + 0.5 * h)
            g = 2.0 * self.L / h
            c = (g * i0 + abs(vg) - self.V_b - u_off) / (g + R)
            i1 = 2.0 * c - i0
        en = self.energy
        hc = h * c
        en.grid += abs(vg) * hc
        en.line_resistance += self.R_s * c * hc
        q = self._book_conduction(hc, c, gate, v_out)
        self.time = t + h
        if event == 'zero':
            self._block_at_current_zero(self.time, i1)
        else:
            self.i_L = i1
            if event == 'over_current':
                self._trip_over_current()
        return q

    def _plain_blocked(self, t: float, h: float, vg_mid: float, u_off: float) -> bool:
        """With i_L = 0: whether the bridge stays blocked (BLOCK) until a located start, or the
        piece end, where self.time is then set; False when it is forward biased at t."""
        V_b = self.V_b
        if abs(self.grid_voltage(t)) - V_b - u_off > 0.0:
            return False
        self.mode = BLOCK
        if abs(vg_mid) - V_b - u_off <= 0.0 and abs(self.grid_voltage(t + h)) - V_b - u_off <= 0.0:
            self.time = t + h
            return True
        self.time = t + self._locate(EV_PLAIN_START, t, h, u=u_off)
        self._event(self.time, 'start', 'bridge forward biased: conduction starts')
        return True

    def _plain_event(self, t: float, h: float, gate: bool, i0: float, i1: float, R: float,
                     u_off: float) -> tuple[float, str | None]:
        """(piece length, event) of a conducting piece: i_L reaching zero, h = 2 L i0 / (R i0 - 2 D),
        or the over-current limit, h = 2 L (i0 - lim) / (R (i0 + lim) - 2 D), D the bridge drive at
        the piece's (moving) middle, three fixed-point passes; (h, None) without an event."""
        L, V_b, lim = self.L, self.V_b, self.over_current_limit
        if i1 < 0.0:
            hz = h
            for _ in range(3):
                D = abs(self.grid_voltage(t + 0.5 * hz)) - V_b - u_off
                den = R * i0 - 2.0 * D
                hz = min(h, 2.0 * L * i0 / den) if den > 0.0 else h
            return hz, 'zero'
        if gate and lim > 0.0 and i1 > lim and i0 < lim:
            hz = h
            for _ in range(3):
                D = abs(self.grid_voltage(t + 0.5 * hz)) - V_b - u_off
                den = R * (i0 + lim) - 2.0 * D
                hz = min(h, 2.0 * L * (i0 - lim) / den) if den < 0.0 else h
            return hz, 'over_current'
        return h, None

    def _book_conduction(self, hc: float, c: float, gate: bool, v_out: float) -> float:
        """Ledger of a piece with the inductor conducting at mid current c [A], hc = h c [C]:
        inductor resistance, bridge, switch or diode and link; returns the link charge."""
        en = self.energy
        en.inductor_resistance += self.R_L * c * hc
        en.bridge += self.V_b * hc
        if gate:
            en.switch += self.R_on * c * hc
            return 0.0
        en.diode += self.V_d * hc
        en.delivered += v_out * hc
        return hc

    def _block_at_current_zero(self, when: float, i_end: float) -> None:
        """The located inductor-current zero at ``when``: L i_end^2 / 2 of the piece's end
        current goes to the numerical ledger, i_L = 0 and the bridge blocks."""
        self.energy.numerical += 0.5 * self.L * i_end * i_end
        self.i_L = 0.0
        self.mode = BLOCK
        self._event(when, 'zero', 'inductor current zero (bridge blocks)')

    # ---- EMI filter: states i_f, v_c, i_L
    def _circuit(self) -> tuple:
        """(v_peak, omega, line_phase, L_f, R_f, C_2, L, V_b): the circuit constants of the kernels."""
        return (self.v_peak, self.omega, self.line_phase, self.L_f, self.R_f, self.C_f, self.L, self.V_b)

    def _mid(self, t: float, h: float, mode: int, s: int, R: float, u: float):
        """Midpoint-rule mid values (i_f, v_c, i_L) and v_g(t + h/2) of a piece."""
        return midpoint_values(t, h, mode, s, R, u, *self._circuit(), self.i_f, self.v_c, self.i_L)

    def _locate(self, kind: int, t: float, h: float, mode: int = BLOCK, s: int = 1, R: float = 0.0,
                u: float = 0.0) -> float:
        """Time [s] after t of the first event of this kind inside (0, h] (:func:`locate_event`)."""
        return locate_event(kind, h, t, mode, s, R, u, self.over_current_limit, *self._circuit(),
                            self.i_f, self.v_c, self.i_L)

    def _start_mode(self, u: float) -> None:
        """The conduction mode consistent with the state at a piece start (module doc's modes):
        a reverse-biased conducting diagonal starts an overlap (v_c snapped to 0, its energy
        booked as numerical), a forward-biased bridge with i_L = 0 starts conduction."""
        if self.i_L > 0.0:
            if self.mode == OVERLAP:
                if abs(self.i_f) > self.i_L:
                    self.mode, self.s = COND, (1 if self.i_f > 0.0 else -1)
            elif self.mode != COND or self.s * self.v_c < 0.0:
                if self.s * self.v_c < 0.0:      # reverse biased diagonal: overlap (snap v_c)
                    self.energy.numerical += 0.5 * self.C_f * self.v_c * self.v_c
                    self.v_c = 0.0
                    self.mode = OVERLAP
                else:
                    self.mode = COND
        else:
            self.i_L = 0.0
            if abs(self.v_c) - self.V_b - u > 0.0:
                self.mode, self.s = COND, (1 if self.v_c > 0.0 else -1)
            else:
                self.mode = BLOCK

    def _piece_filter(self, t: float, span: float, gate: bool, v_out: float) -> float:
        """Sub-steps of at most h_max over span [s] from t with a fixed gate; stops at an event.

        Advances self.time (to t + span, or to the located event); returns the link charge.
        The sub-steps are the compiled :func:`filter_substeps`; an event inside the last one
        is located and taken by :meth:`_filter_event`.
        """
        u = 0.0 if gate else v_out + self.V_d
        R = self.R_L + (self.R_on if gate else 0.0)
        self._start_mode(u)
        mode, s = self.mode, self.s
        (t, self.i_f, self.v_c, self.i_L, h, event, q, e_grid, e_line, e_ind, e_sq) = filter_substeps(
            mode, s, gate, self.over_current_limit, self.V_b, u, R, self.R_f, 2.0 * self.L_f,
            2.0 * self.C_f, 2.0 * self.L, self.v_peak, self.omega, self.line_phase, self.h_max, t, span,
            self.i_f, self.v_c, self.i_L)
        self.time = t
        self._book(e_grid, e_line, e_ind, e_sq, q, gate, v_out)
        if event:
            q += self._filter_event(t, h, mode, s, R, u, gate, v_out)
        return q

    def _book(self, e_grid, e_line, qc, sq, q, gate, v_out):
        """Ledger of sub-steps: e_line = int i_f^2, qc = int i_L, sq = int i_L^2, q = link charge."""
        en = self.energy
        en.grid += e_grid
        en.line_resistance += self.R_f * e_line
        en.bridge += self.V_b * qc
        en.inductor_resistance += self.R_L * sq
        if gate:
            en.switch += self.R_on * sq
        else:
            en.diode += self.V_d * q
            en.delivered += v_out * q

    def _filter_event(self, t, h, mode, s, R, u, gate, v_out) -> float:
        """The sub-step of length h from t holds an event: locate it, integrate to it, act."""
        i_f0, v_c0, i_L0 = self.i_f, self.v_c, self.i_L
        lim = self.over_current_limit
        cands = []
        a, b, c, vg = self._mid(t, h, mode, s, R, u)
        i_f1, v_c1, i_L1 = 2.0 * a - i_f0, 2.0 * b - v_c0, 2.0 * c - i_L0
        oc = gate and lim > 0.0 and i_L0 < lim
        if mode == COND:
            if i_L1 < 0.0:
                cands.append(('zero', EV_ZERO))
            if s * v_c1 < 0.0 < s * v_c0:
                cands.append(('overlap', EV_OVERLAP))
            if oc and i_L1 > lim:
                cands.append(('over_current', EV_OVER_CURRENT))
        elif mode == OVERLAP:
            if i_L1 - i_f1 <= 0.0:
                cands.append(('overlap_end+', EV_OVERLAP_END_POS))
            if i_L1 + i_f1 <= 0.0:
                cands.append(('overlap_end-', EV_OVERLAP_END_NEG))
            if oc and i_L1 > lim:
                cands.append(('over_current', EV_OVER_CURRENT))
        else:
            thr = self.V_b + u
            if v_c1 - thr > 0.0:
                cands.append(('start+', EV_START_POS))
            if -v_c1 - thr > 0.0:
                cands.append(('start-', EV_START_NEG))
        best, event = h, None
        for name, kind in cands:
            th = self._locate(kind, t, h, mode, s, R, u)
            if th <= best:
                best, event = th, name
        h = best
        a, b, c, vg = self._mid(t, h, mode, s, R, u)
        i_f1, v_c1, i_L1 = 2.0 * a - i_f0, 2.0 * b - v_c0, 2.0 * c - i_L0
        en = self.energy
        en.grid += h * vg * a
        en.line_resistance += h * self.R_f * a * a
        q = self._book_conduction(h * c, c, gate, v_out) if mode != BLOCK else 0.0
        self.i_f, self.v_c, self.i_L = i_f1, v_c1, i_L1
        self.time = when = t + h
        if event == 'zero':
            self._block_at_current_zero(when, i_L1)
        elif event == 'overlap':
            en.numerical += 0.5 * self.C_f * v_c1 * v_c1
            self.v_c = 0.0
            self.mode = OVERLAP
            self._event(when, 'overlap', 'bridge commutation starts (both diagonals conduct)')
        elif event is not None and event.startswith('overlap_end'):
            self.mode, self.s = COND, (1 if event[-1] == '+' else -1)
            self._event(when, 'overlap_end', 'bridge commutation ends')
        elif event is not None and event.startswith('start'):
            self.mode, self.s = COND, (1 if event[-1] == '+' else -1)
            self._event(when, 'start', 'bridge forward biased: conduction starts')
        elif event == 'over_current':
            self._trip_over_current()
        return q

    def _trip_over_current(self) -> None:
        self.over_current = True
        self.gate = False
        self._oc_period = math.floor(self.time * self.f_pwm + 1e-9)
        self.event_counts['over_current'] += 1
        self._protection(self.time, 'over_current', f'boost over-current: i_L = {self.i_L:.3f} A '
                         f'above {self.over_current_limit:g} A: switch opened')

    def _protection(self, when: float, kind: str, text: str) -> None:
        """A protection trip: logged, and passed to on_protection (the plant's fault record)."""
        self._log(when, text)
        if self.on_protection is not None:
            self.on_protection(kind, when, text)

    def _event(self, when: float, kind: str, text: str) -> None:
        """Count a switching event; log it only with log_switching_events (80 kHz: many)."""
        self.event_counts[kind] += 1
        self.last_event = (when, kind)
        if self.log_switching_events:
            self._log(when, text)

    def _log(self, when: float, text: str) -> None:
        ev = self.events
        if len(ev) > _EVENT_LOG_MAX:
            del ev[:_EVENT_LOG_MAX // 2]
        ev.append((when, text))
