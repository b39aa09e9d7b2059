"""Switching-level boost PFC front end of 000 ch. III (Fig. 3.1), no rclpy.

Grid -> optional EMI filter (C1, L1 + L2, C2) -> diode bridge -> boost inductor L -> boost
switch, or boost diode into the split capacitor string (:class:`~.dc_link.DcLink`,
``current_fed``). The arithmetic is :mod:`.front_end_kernel` (state in float64 arrays); this
class keeps the API, the event log and the trip callback. Circuit, equations, events, PWM and
protections (000 3.3): docs/models.md "Boost PFC front end".
"""
from __future__ import annotations

import math

import numpy as np

from drive_common.compiled import interpreted

from ..parameters import PLANT_SCHEMA
from . import front_end_kernel as FK
from .dc_link import array_slot
from .front_end_kernel import BLOCK, KIND_NAMES

TWO_PI = 2.0 * math.pi
SQRT2 = math.sqrt(2.0)
CARRIERS = ('triangle', 'sawtooth')

_EVENT_LOG_MAX = 10_000
_EVENT_ROWS = 4096           # event rows one advance can log
# text of each logged switching event kind (KIND_NAMES order)
_EVENT_TEXT = ('inductor current zero (bridge blocks)', 'bridge forward biased: conduction starts',
               'bridge commutation starts (both diagonals conduct)', 'bridge commutation ends')
_front_end_values = FK.front_end_values     # compiled: one dispatch for all the values
_losses, _grid_voltage = interpreted(FK.losses), interpreted(FK.grid_voltage)


def _keyword(name: str) -> str:
    """The FrontEnd keyword of a ``front_end.*`` plant parameter: front_end.filter.inductance ->
    filter_inductance, front_end.boost.diode_drop -> diode_drop (boost.resistance: of the inductor)."""
    if name == 'front_end.boost.resistance':
        return 'inductor_resistance'
    return name.removeprefix('front_end.').removeprefix('boost.').replace('.', '_')


PARAMETER_NAMES = {name: _keyword(name) for name in PLANT_SCHEMA.names()
                   if name.startswith('front_end.') and name != 'front_end.enabled'}
"""Plant-schema name -> FrontEnd keyword."""
DEFAULTS = {key: PLANT_SCHEMA[name].default for name, key in PARAMETER_NAMES.items()}
"""FrontEnd keyword -> its default (the plant schema's)."""


def _fv_property(slot: int, doc: str, kind: type = float) -> property:
    """A read-only FrontEnd value: front_end_kernel.front_end_values slot (FV_*) now."""
    return property(lambda self: kind(self._value(slot)), doc=doc)


class FrontEndLedger:
    """Cumulative front-end energies since start [J], held in the front end's state array."""

    grid = array_slot(FK.FX_GRID, 'delivered by the grid (incl. C1\'s reactive exchange)')
    delivered = array_slot(FK.FX_DELIVERED, 'into the DC link: v_o(predicted) * boost-diode charge')
    line_resistance = array_slot(FK.FX_LINE, 'supply + EMI-filter series resistances')
    inductor_resistance = array_slot(FK.FX_IND, 'R_L i_L^2')
    bridge = array_slot(FK.FX_BRIDGE, '2 V_f i_L')
    switch = array_slot(FK.FX_SWITCH, 'R_on i_L^2')
    diode = array_slot(FK.FX_DIODE, 'V_fd i_L')
    numerical = array_slot(FK.FX_NUM, 'energy of the snaps onto event surfaces (~1e-20 J)')

    def __init__(self, x: np.ndarray | None = None) -> None:
        self.x = np.zeros(FK.FX_SIZE) if x is None else x

    @property
    def losses(self) -> float:
        return float(_losses(self.x))


class FrontEnd:
    """Grid + EMI filter + diode bridge + boost stage, integrated by :meth:`advance`.

    Keywords: those of PARAMETER_NAMES (SI units; missing ones take DEFAULTS); time [s]: start.
    Parameters in ``fp``, state in ``fx`` (:mod:`.front_end_kernel` slots), advanced in place.
    """

    time = array_slot(FK.FX_TIME, 's, time the state is at', 'fx')
    i_f = array_slot(FK.FX_IF, 'A, filter inductor current', 'fx')
    v_c = array_slot(FK.FX_VC, 'V, C2 (bridge input) voltage', 'fx')
    i_L = array_slot(FK.FX_IL, 'A, boost inductor current', 'fx')
    duty = array_slot(FK.FX_DUTY, 'duty command', 'fx')
    s = array_slot(FK.FX_S, 'bridge polarity of the conducting diagonal (+-1)', 'fx', int)
    mode = array_slot(FK.FX_MODE, 'BLOCK / COND / OVERLAP', 'fx', int)
    _oc_period = array_slot(FK.FX_OC_PERIOD, 'PWM period index of the last over-current trip', 'fx', int)
    gate = array_slot(FK.FX_GATE, 'boost switch state at self.time', 'fx', bool)
    enable = array_slot(FK.FX_ENABLE, 'enable command', 'fx', bool)
    over_current = array_slot(FK.FX_OC, 'over-current protection active', 'fx', bool)
    over_voltage = array_slot(FK.FX_OV, 'over-voltage protection active', 'fx', bool)
    log_switching_events = array_slot(FK.FP_LOG, 'log zero / start / overlap events too (many)', 'fp', bool)

    def __init__(self, *, time: float = 0.0, **settings) -> None:
        unknown = set(settings) - set(DEFAULTS)
        if unknown:
            raise TypeError(f'FrontEnd: unknown keyword(s) {", ".join(sorted(unknown))}')
        self.fp = np.zeros(FK.FP_SIZE)
        self.fx = np.zeros(FK.FX_SIZE)
        self._ev = np.zeros((_EVENT_ROWS, 4))
        self._fv = np.zeros(FK.FV_SIZE)
        settings = {**DEFAULTS, **settings}
        self.filter_enabled = bool(settings.pop('filter_enabled'))
        self.configure(**settings)
        self.time = float(time)
        self.v_c = self.grid_voltage(self.time) if self.filter_enabled else 0.0
        self.s = 1
        self.mode = BLOCK
        self._oc_period = -1
        self.fx[FK.FX_LAST_T], self.fx[FK.FX_LAST_KIND] = math.nan, -1
        self.events: list[tuple[float, str]] = []   # (time, what), bounded
        self.on_protection = None   # callable(kind, time, text) per trip ('over_current' / 'over_voltage')
        self.energy = FrontEndLedger(self.fx)

    @property
    def event_counts(self) -> dict[str, int]:
        """Events counted since start, by kind (KIND_NAMES)."""
        return {name: int(n) for name, n in zip(KIND_NAMES, self.fx[FK.FX_COUNTS:].tolist())}

    @property
    def last_event(self) -> tuple[float, str]:
        """(time, kind) of the last switching event ((nan, '') before any)."""
        when, kind = self.fx[FK.FX_LAST_T:FK.FX_LAST_KIND + 1].tolist()
        return (when, KIND_NAMES[int(kind)] if kind >= 0 else '')

    @classmethod
    def from_params(cls, p: dict, time: float = 0.0) -> 'FrontEnd':
        """Build from a plant parameter snapshot (names in PARAMETER_NAMES)."""
        kw = {k: p[n] for n, k in PARAMETER_NAMES.items() if n in p}
        return cls(time=time, **kw)

    def reconfigure(self, p: dict) -> None:
        """Runtime update from a plant snapshot, state kept (a new filter.enabled needs a rebuild)."""
        kw = {k: p[n] for n, k in PARAMETER_NAMES.items() if n in p and k != 'filter_enabled'}
        self.configure(**kw)

    def configure(self, **kw) -> None:
        """Set keywords of PARAMETER_NAMES (not filter_enabled) and rebuild ``fp``."""
        for k, v in kw.items():
            setattr(self, k, v)
        if self.pwm_carrier not in CARRIERS:
            raise ValueError(f'pwm_carrier {self.pwm_carrier!r} is not one of {CARRIERS}')
        self.v_peak = SQRT2 * float(self.line_voltage)
        R_s = float(self.line_resistance)
        R_L = float(self.inductor_resistance)
        if self.filter_enabled:     # supply impedance in series with L1 + L2
            L = float(self.inductance)
            L_f = 2.0 * float(self.filter_inductance) + float(self.line_inductance)
            R_f = 2.0 * float(self.filter_resistance) + R_s
            R_plain = R_L
        else:                       # supply impedance moved to the DC side of the bridge
            L = float(self.inductance) + float(self.line_inductance)
            L_f = R_f = 0.0
            R_plain = R_L + R_s
        C_f = float(self.filter_capacitance)          # C2 (bridge side) = C1 (grid side)
        self.fp[FK.FP_VPEAK:FK.FP_LOG] = (
            self.v_peak, TWO_PI * float(self.line_frequency), float(self.line_phase), R_s, R_L, L, L_f,
            R_f, R_plain, C_f, C_f, 2.0 * float(self.bridge_diode_drop), float(self.switch_resistance),
            float(self.diode_drop), float(self.pwm_frequency), self.pwm_carrier == 'triangle',
            float(self.max_step) if self.filter_enabled else math.inf, self.filter_enabled,
            float(self.over_current_limit), float(self.over_voltage_limit), bool(self.protection_latched))

    def set_duty(self, duty: float, enable: bool) -> None:
        """Latch the duty command (held until the next call)."""
        self.duty = min(1.0, max(0.0, float(duty)))
        self.enable = bool(enable)

    def reset_protection(self) -> None:
        """Clear latched flags (they re-trip at once if the condition still holds)."""
        self.over_current = self.over_voltage = False

    def _value(self, slot: int) -> float:
        """One of front_end_kernel.front_end_values (FV_*) now."""
        _front_end_values(self.fp, self.fx, self.time, self._fv)
        return float(self._fv[slot])

    protection = _fv_property(FK.FV_PROT, 'PlantState PROTECTION_BOOST_* bits active', int)
    switch_enabled = _fv_property(FK.FV_SWITCH, 'boost switching enabled after protections', bool)
    applied_duty = _fv_property(FK.FV_DUTY, 'PlantState.boost_duty (0 while held off)')
    rectified_voltage = _fv_property(FK.FV_RECT, 'V, |bridge input|, as the PFC senses it')
    grid_current = _fv_property(FK.FV_GRID_I, 'A, line current (filter: i_f + C1 dv_g/dt)')
    inductor_current = property(lambda self: self.i_L, doc='A, boost inductor current')

    def grid_voltage(self, t: float) -> float:
        return _grid_voltage(self.fp, t)

    def stored_energy(self) -> float:
        """J: boost inductor, filter inductors, C2 and C1 (C1 at the grid voltage now)."""
        return self._value(FK.FV_STORED)

    def measurement(self) -> tuple[float, float]:
        """(rectified_voltage, inductor_current) for PfcMeasurement at self.time."""
        return self.rectified_voltage, self.i_L

    def balance_error(self, stored_initial: float) -> float:
        """grid - (stored - stored_initial) - losses - delivered [J] (round-off only)."""
        en = self.energy
        return en.grid - (self.stored_energy() - stored_initial) - en.losses - en.delivered

    def advance(self, t: float, dt: float, v_out: float) -> float:
        """Integrate [t, t + dt] with the positive rail held at v_out [V] (:func:`.front_end_kernel.advance`);
        the charge [C] delivered into it. Events inside are taken in order (:meth:`take_event`)."""
        q, n_ev = FK.advance(self.fp, self.fx, self._ev, 0, t, dt, v_out)
        for when, kind, _, value in self._ev[:min(n_ev, _EVENT_ROWS)].tolist():
            self.take_event(when, int(kind), value)
        return q

    def take_event(self, when: float, kind: int, value: float) -> None:
        """A logged event row (kind EV_FRONT_END + KIND_*; value: i_L or v_o of a trip) into the
        log; a trip also to on_protection (the plant's fault record)."""
        kind -= FK.EV_FRONT_END
        if kind == FK.KIND_OVER_CURRENT:
            trip, text = 'over_current', (f'boost over-current: i_L = {value:.3f} A '
                                          f'above {self.over_current_limit:g} A: switch opened')
        elif kind == FK.KIND_OVER_VOLTAGE:
            trip, text = 'over_voltage', (f'boost over-voltage: v_o = {value:.3f} V above '
                                          f'{self.over_voltage_limit:g} V: switch opened')
        else:
            trip, text = None, _EVENT_TEXT[kind]
        log_event(self.events, when, text)
        if trip is not None and self.on_protection is not None:
            self.on_protection(trip, when, text)


def log_event(events: list, when: float, text: str) -> None:
    """Append (when, text) to an event log bounded at about _EVENT_LOG_MAX entries."""
    if len(events) > _EVENT_LOG_MAX:
        del events[:_EVENT_LOG_MAX // 2]
    events.append((when, text))
