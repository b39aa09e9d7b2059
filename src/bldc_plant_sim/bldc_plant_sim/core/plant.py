"""PlantCore: motor + inverter + DC link + load + sensors + protection, stepped per base tick.

Between events every conducting phase follows an exact exponential (back-EMFs at the segment's
mid angle); current zeros, the peak-current trip and the end of a dead time split the step, and
energies use exact integrals of i and i^2 (docs/models.md "Integration of a base tick"). The
arithmetic runs in :mod:`.plant_kernel` (one call per base tick); this class keeps the API, the
event log and the fault record.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from drive_common.parameters import ParameterError
from drive_common.samples import ALL_OFF, DriveSample, PfcSample

from ..parameters import PLANT_SCHEMA, effective_params
from . import front_end_kernel as FK
from . import plant_kernel as K
from .dc_link import DcLink, array_slot
from .link_kernel import DC_VL, DC_VU
from .faults import FaultKind, FaultRecord
from .front_end import FrontEnd, log_event
from .inverter import Inverter
from .load import LoadMachine
from .motor import Motor
from .protection import MOTOR_OVER_CURRENT, SHOOT_THROUGH, PeakCurrentTrip
from .sensors import Sensors

TWO_PI = 2.0 * math.pi
NAN = math.nan


@dataclass(slots=True)
class PlantStateSample:
    """dtc_msgs/PlantState without the header (field names equal the message's)."""

    step: int
    phase_current: tuple = (0.0, 0.0, 0.0)
    back_emf: tuple = (0.0, 0.0, 0.0)
    flux_linkage: tuple = (0.0, 0.0, 0.0)
    terminal_voltage: tuple = (0.0, 0.0, 0.0)
    neutral_voltage: float = 0.0
    electromagnetic_torque: float = 0.0
    load_torque: float = 0.0
    rotor_angle: float = 0.0
    mechanical_angle: float = 0.0
    mechanical_speed: float = 0.0
    dc_link_voltage: float = 0.0
    upper_capacitor_voltage: float = 0.0
    lower_capacitor_voltage: float = 0.0
    grid_voltage: float = NAN
    grid_current: float = NAN
    rectified_voltage: float = NAN
    inductor_current: float = NAN
    applied_switch_on: tuple = ALL_OFF
    boost_duty: float = 0.0
    boost_switch_enabled: bool = False
    protection: int = 0
    safe_state: bool = False
    energy_grid_input: float = 0.0
    energy_dc_source: float = 0.0
    energy_copper_loss: float = 0.0
    energy_device_loss: float = 0.0
    energy_front_end_loss: float = 0.0
    energy_friction_loss: float = 0.0
    energy_mechanical_output: float = 0.0
    energy_stored: float = 0.0
    fault_count: int = 0
    fault_counts: tuple = (0,) * len(FaultKind)
    first_fault_kind: int = 0
    first_fault_time: float = NAN


def state_sample(step: int, sv, applied: tuple, extras: dict) -> PlantStateSample:
    """A PlantStateSample from plant_kernel.state_values (SV_* order), applied switches and extras."""
    (e0, e1, e2, f0, f1, f2, v0, v1, v2, vn, te, rotor, stored, vp, vu, vl, e_src, copper, device,
     friction, mech, theta_m, omega, t_load, i0, i1, i2) = sv
    return PlantStateSample(
        step=step, phase_current=(i0, i1, i2), back_emf=(e0, e1, e2), flux_linkage=(f0, f1, f2),
        terminal_voltage=(v0, v1, v2), neutral_voltage=vn, electromagnetic_torque=te,
        load_torque=t_load, rotor_angle=rotor, mechanical_angle=theta_m, mechanical_speed=omega,
        dc_link_voltage=vp, upper_capacitor_voltage=vu, lower_capacitor_voltage=vl,
        applied_switch_on=applied, energy_dc_source=e_src, energy_copper_loss=copper,
        energy_device_loss=device, energy_friction_loss=friction, energy_mechanical_output=mech,
        energy_stored=stored, **extras)


# PlantState's front-end fields: (name, front_end_kernel.front_end_values slot, type)
FRONT_END_FIELDS = (('grid_voltage', FK.FV_GRID_V, float), ('grid_current', FK.FV_GRID_I, float),
                    ('rectified_voltage', FK.FV_RECT, float), ('inductor_current', FK.FV_IL, float),
                    ('boost_duty', FK.FV_DUTY, float), ('boost_switch_enabled', FK.FV_SWITCH, bool),
                    ('energy_grid_input', FK.FV_E_GRID, float),
                    ('energy_front_end_loss', FK.FV_E_LOSS, float))


NO_FRONT_END = {name: getattr(PlantStateSample(0), name) for name, _, _ in FRONT_END_FIELDS}
"""PlantState's front-end fields without a front end (their defaults: NaN, 0, False)."""


def front_extras(fv: list) -> dict:
    """PlantState's front-end fields from a front_end_values row (FV_* order)."""
    return {name: kind(fv[slot]) for name, slot, kind in FRONT_END_FIELDS}


# the fault of each front-end protection trip (FrontEnd.on_protection's kind)
BOOST_FAULTS = {'over_current': FaultKind.BOOST_OVER_CURRENT, 'over_voltage': FaultKind.BOOST_OVER_VOLTAGE}


def fault_extras(faults: FaultRecord) -> dict:
    """PlantState's fault fields of a fault record."""
    return dict(fault_count=faults.total, fault_counts=tuple(faults.counts),
                first_fault_kind=int(faults.first_kind), first_fault_time=faults.first_time)


def sv_slots() -> dict:
    """{PlantState field: SV_* slot or (first slot, width)}, read off state_sample fed 0, 1, 2, ..."""
    probe = state_sample(0, [float(n) for n in range(K.SV_SIZE)], (), {})
    default = PlantStateSample(0)
    out = {}
    for f in fields(PlantStateSample):
        value = getattr(probe, f.name)
        if f.name != 'applied_switch_on' and value == value and value != getattr(default, f.name):
            out[f.name] = (int(value[0]), len(value)) if isinstance(value, tuple) else int(value)
    return out


class Memo(dict):
    """fn's value per key, computed at the first lookup ``memo[key]`` (hits cost a dict lookup)."""

    def __init__(self, fn) -> None:
        super().__init__()
        self.fn = fn

    def __missing__(self, key):
        value = self[key] = self.fn(key)
        return value


class EnergyLedger:
    """Cumulative losses and work since start [J] in the core's state array (ST_* slots)."""

    copper = array_slot(K.ST_CU, 'R int i^2 [J]', 'st')
    device = array_slot(K.ST_DEV, 'device drops [J]', 'st')
    friction = array_slot(K.ST_FRIC, 'B w^2 [J]', 'st')
    mechanical = array_slot(K.ST_MECH, 'load work [J]', 'st')

    def __init__(self, st: np.ndarray) -> None:
        self.st = st
        self.stored_initial = 0.0     # stored energy at start (moved when a part is rebuilt)


class PlantCore:
    """The plant of docs/architecture.md "The plant" without ROS (API: "Core APIs").

    params: a PLANT_SCHEMA snapshot (missing names: defaults; ``motor.file`` applied by
    :func:`~bldc_plant_sim.parameters.effective_params`); ``self.params``: the values used.
    """

    def __init__(self, params: dict | None = None) -> None:
        p = self.validate(params or {})
        self._requested = PLANT_SCHEMA.resolve(params, strict=False)
        self.params = p
        self.base_tick = p['base_tick']
        self.step = 0
        self.time = 0.0
        self.motor = Motor.from_params(p)
        self.inverter = Inverter.from_params(p)
        self.topology = self.inverter.topology
        self.dc = DcLink.from_params(p)
        self.faults = FaultRecord()
        self.fe = self._attach(FrontEnd.from_params(p)) if p['front_end.enabled'] else None
        self.shoot_through_policy = p['inverter.shoot_through']
        self.load = LoadMachine.from_params(p)
        self.sensors = Sensors(p, self.motor.pole_pairs)
        self.trip = PeakCurrentTrip(p['protection.peak_current'])
        self._buf = np.zeros(K.B_SIZE)     # every float array the kernels use (plant_kernel B_*)
        self.st = self._buf[K.B_ST:K.B_DC]
        self._prm = self._buf[K.B_PRM:K.B_SV]
        self._sv = self._buf[K.B_SV:K.B_RES]
        self._head = self.st[K.ST_I:K.ST_TH + 1]          # i_a, i_b, i_c, w, theta (drive_sample)
        self._link_v = self._buf[K.B_DC + DC_VU:K.B_DC + DC_VL + 1]   # v_u, v_l
        self._derive_constants(p['integration.max_step'])
        self.theta_m = p['motor.initial_angle']
        self.omega = p['motor.initial_speed']
        if self.load.dynamometer:
            self.omega = self.load.speed
        self._count0 = self.sensors.encoder_count(self.theta_m)
        self._t_load = self.load.load_torque(self.omega)
        self._safe = 0
        self._commanded = self.inverter.all_off()
        self._legs = self._commanded
        self._applied = ALL_OFF
        self._duty = (0.0, False)
        self.events: list[tuple[float, str]] = []   # (time, what) of located events, bounded
        self._fv = np.zeros(FK.FV_SIZE)     # front_end_values' scratch
        self.energy = EnergyLedger(self.st)
        self.energy.stored_initial = self.stored_energy()

    @property
    def i(self) -> list:
        """Phase currents [A]."""
        return self.st[K.ST_I:K.ST_I + 3].tolist()

    omega = array_slot(K.ST_W, 'mechanical speed [rad/s]', 'st')
    theta_m = array_slot(K.ST_TH, 'mechanical angle [rad]', 'st')
    _t_load = array_slot(K.ST_TL, 'load torque [N m]', 'st')
    _elapsed = array_slot(K.ST_EL, 'time integrated in the current tick [s]', 'st')

    @staticmethod
    def validate(params: dict, previous: dict | None = None,
                 previous_effective: dict | None = None) -> dict:
        """Full validated snapshot of the values used (defaults, motor file, explicit params);
        raises ParameterError/OSError. previous / previous_effective: see effective_params."""
        snap = effective_params(params, previous, previous_effective=previous_effective)
        if snap['motor.backemf.shape'] == 'table':
            Motor.from_params(snap)   # reads the table file now: bad files are refused up front
        return snap

    def check_params(self, params: dict) -> dict:
        """The values this plant would use for a new requested snapshot, refusing what it cannot
        take after t = 0 (a new base tick, front end on / off)."""
        snap = self.validate(params, self._requested, self.params)
        if self.step > 0 and snap['base_tick'] != self.base_tick:
            raise ParameterError(f"base_tick: cannot change from {self.base_tick} s after the "
                                 'simulation started')
        if self.step > 0 and snap['front_end.enabled'] != self.params['front_end.enabled']:
            raise ParameterError('front_end.enabled: cannot change after the simulation started '
                                 '(the energy ledger would lose its input)')
        return snap

    def reconfigure(self, params: dict) -> None:
        """Apply a new snapshot at a sample boundary, state kept: runtime parameters in place,
        changed held ones rebuild their part (the stored-energy baseline moves with it)."""
        p = self.check_params(params)
        requested = PLANT_SCHEMA.resolve(params, strict=False)
        old = self.params
        changed = {n for n in p if p[n] != old.get(n)}
        stored_before = self.stored_energy()
        if any(n.startswith('motor.') and n not in ('motor.initial_angle', 'motor.initial_speed')
               for n in changed):
            self.motor = Motor.from_params(p)
        if changed & {'inverter.topology', 'inverter.midpoint_phase'}:
            self.inverter = Inverter.from_params(p)
            self.topology = self.inverter.topology
            self._commanded = self._legs = self.inverter.all_off()
        self.inverter.set_drops(p['inverter.v_ce'], p['inverter.v_d'], p['inverter.r_on'])
        self.inverter.dead_time = p['inverter.dead_time']
        if any(n.startswith('dc_link.') and n != 'dc_link.source_current' for n in changed):
            source_energy = self.dc.energy_source
            self.dc = DcLink.from_params(p)
            self.dc.energy_source = source_energy
        self.dc.source_current = p['dc_link.source_current']
        fe = self.fe
        if not p['front_end.enabled']:
            self.fe = None
        elif fe is None:
            self.fe = self._attach(FrontEnd.from_params(p, time=self.time))
        else:
            # A line voltage / phase step changes C1's energy at once: the grid supplies
            # that jump (booked as grid input, not as a move of the stored-energy baseline).
            if p['front_end.filter.enabled'] != fe.filter_enabled:
                self.fe = self._rebuilt_front_end(p)   # the baseline moves below
            else:
                e0 = fe.stored_energy()
                fe.reconfigure(p)
                if changed & {'front_end.line_voltage', 'front_end.line_phase'}:
                    jump = fe.stored_energy() - e0
                    fe.energy.grid += jump
                    stored_before += jump
        self.load.configure(p['load.mode'], p['load.torque'], p['load.viscous'], p['load.speed'])
        if changed & {'sensors.seed', 'sensors.encoder_pulses', 'motor.pole_pairs'}:
            self.sensors = Sensors(p, self.motor.pole_pairs)
            self._count0 = self.sensors.encoder_count(self.theta_m)
        self.sensors.configure(p)
        self.trip.level = p['protection.peak_current']
        self.shoot_through_policy = p['inverter.shoot_through']
        self.params = p
        self._requested = requested
        self._derive_constants(p['integration.max_step'])
        self.energy.stored_initial += self.stored_energy() - stored_before

    def _rebuilt_front_end(self, p: dict) -> FrontEnd:
        """A new FrontEnd for a changed filter.enabled: keeps i_L, commands, flags and the ledger."""
        old = self.fe
        fe = FrontEnd.from_params(p, time=self.time)
        fe.i_L = old.i_L
        fe.duty, fe.enable = old.duty, old.enable
        fe.over_current, fe.over_voltage = old.over_current, old.over_voltage
        fe.fx[FK.FX_GRID:] = old.fx[FK.FX_GRID:]     # the energy ledger and the event counts
        fe.events = old.events
        return self._attach(fe)

    def _attach(self, fe: FrontEnd) -> FrontEnd:
        """Route the front end's protection trips into the fault record."""
        fe.on_protection = lambda kind, when, text: self.faults.record(BOOST_FAULTS[kind], when,
                                                                       self.step, text)
        return fe

    def _derive_constants(self, max_step: float) -> None:
        """The kernels' parameter array (plant_kernel PR_*), the back-EMF table and buffers."""
        inv, m = self.inverter, self.motor
        # memos: gate tuple -> (leg codes, shoot-through legs), leg codes <-> code, -> applied gates
        self._legs_of = Memo(lambda switch_on: (inv.legs(switch_on), inv.shoot_through_legs(switch_on)))
        self._codes = Memo(K.leg_code)
        self._legs_of_code = Memo(lambda code: tuple(K.legs_of_code(code).tolist()))
        self._switches_of = Memo(inv.switches)
        can_open = inv.v_ce + inv.v_d > 0.0   # switched legs have a blocking band at i = 0
        substeps = max(1, math.ceil(self.base_tick / max_step - 1e-9))
        h = self.base_tick / substeps
        tau = m.time_constant
        shape = m.backemf
        self._adopt()
        prm = self._prm
        prm[[K.PR_P, K.PR_SCALE, K.PR_POINTS, K.PR_R, K.PR_TAU, K.PR_AH, K.PR_H]] = (
            m.pole_pairs, shape.lut_scale, shape.points, m.resistance, tau, math.exp(-h / tau), h)
        prm[[K.PR_VCE, K.PR_VD, K.PR_RON, K.PR_J, K.PR_B]] = (inv.v_ce, inv.v_d, inv.r_on,
                                                             m.inertia, m.friction)
        prm[[K.PR_CAN_OPEN, K.PR_DC, K.PR_DEAD, K.PR_N, K.PR_TICK]] = (
            can_open, self.dc.mode_code, inv.dead_time, substeps, self.base_tick)
        prm[K.PR_LM] = m.inductance
        self._lut = shape.lut_k_array.copy()
        self._lut_psi = shape.lut_psi_array.copy()
        self._off_code = self._codes[inv.all_off()]   # a trip inside a tick ends there
        self._ev = np.zeros(((substeps + 2) * (K.MAX_EVENTS_PER_STEP + 2), 4))

    def _adopt(self) -> None:
        """Move the DC link's and the load's state arrays into the core's buffer (views)."""
        for part, lo, hi in ((self.dc, K.B_DC, K.B_LOAD), (self.load, K.B_LOAD, K.B_PRM)):
            view = self._buf[lo:hi]
            if part.x is not view:
                view[:] = part.x
                part.x = view

    def wrong_topology(self, topology: int) -> str | None:
        """Why a gate command for a topology-switch inverter cannot be applied, or None."""
        if topology != self.topology:
            return f'gate command for a {topology}-switch inverter, the plant has {self.topology}'
        return None

    def step_of(self, time: float) -> int:
        """Base tick index at sim time [s] (rounded to the nearest tick)."""
        return int(round(time / self.base_tick))

    def apply_gates(self, switch_on: tuple) -> None:
        """Latch SW1..SW6 until the next call (forced off by safe state or trip); a shoot-through
        is a fault, then safe state or interlock per ``inverter.shoot_through`` (docs/faults.md)."""
        self._commanded, shorted = self._legs_of[switch_on]
        if shorted:
            self._shoot_through(shorted)

    def _shoot_through(self, shorted: str) -> None:
        safe = self.shoot_through_policy == 'safe_state'
        action = 'safe state entered' if safe else 'leg(s) turned off (interlock)'
        self.faults.record(FaultKind.SHOOT_THROUGH, self.time, self.step,
                           f'shoot-through requested on leg {",".join(shorted)}: {action}',
                           leg=','.join(shorted), policy=self.shoot_through_policy)
        if safe:
            self.enter_safe_state(SHOOT_THROUGH)

    def apply_duty(self, duty: float, enable: bool) -> None:
        """Latch the boost duty command until the next call (duty 0 / off in the safe state)."""
        self._duty = (min(1.0, max(0.0, float(duty))), bool(enable))
        if self.fe is not None:
            self.fe.set_duty(*((0.0, False) if self._safe else self._duty))

    def enter_safe_state(self, reason: int) -> None:
        """All switches off (boost off) until leave_safe_state(reason)."""
        self._safe |= int(reason)
        if self.fe is not None:
            self.fe.set_duty(0.0, False)

    def leave_safe_state(self, reason: int) -> None:
        """Clear one reason; the inverter and the boost take the latched commands again."""
        was_safe = self.in_safe_state
        self._safe &= ~int(reason)
        self._resume(was_safe)

    @property
    def in_safe_state(self) -> bool:
        """PlantState.safe_state: a safe-state reason or the latched motor trip."""
        return bool(self._safe or self.trip.tripped)

    def _resume(self, was_safe: bool) -> None:
        """Without a safe-state reason the boost takes the latched duty; a safe state left is noted."""
        if self.fe is not None and not self._safe:
            self.fe.set_duty(*self._duty)
        if was_safe and not self.in_safe_state:
            self.faults.note(self.time, self.step, 'safe state left: switches follow the commands again')

    def reset_protection(self) -> tuple[bool, str]:
        """Reset the latched peak-current trip (refused while the current is above the level)
        and the latched boost protections (they re-trip at once if the cause persists)."""
        was_safe = self.in_safe_state
        ok, text = self.trip.reset(self.i)
        if self._safe & SHOOT_THROUGH:
            self._safe &= ~SHOOT_THROUGH
            text += '; shoot-through safe state reset'
        fe = self.fe
        if fe is not None and fe.protection:
            fe.reset_protection()
            text += '; boost protections reset'
        self._resume(was_safe)
        return ok, text

    @property
    def protection(self) -> int:
        """PlantState PROTECTION_* bits: motor trip, boost over-current / over-voltage, safe state."""
        return self.protection_outside_front_end | (self.fe.protection if self.fe is not None else 0)

    @property
    def protection_outside_front_end(self) -> int:
        """The PROTECTION_* bits of the motor trip and the safe state."""
        return (MOTOR_OVER_CURRENT if self.trip.tripped else 0) | self._safe

    def drive_sample(self) -> DriveSample:
        """Sensed drive quantities at t_k."""
        m = self.motor
        i0, i1, i2, omega, theta_m = self._head.tolist()
        v_up, v_lo = self._link_v.tolist()
        return self.sensors.sample(self.step, self.time, [i0, i1, i2], v_up + v_lo, v_lo, theta_m,
                                   self._count0, omega, m.backemf.hall_code(m.pole_pairs * theta_m))

    def pfc_sample(self) -> PfcSample | None:
        """Sensed boost quantities at t_k (None without the front end)."""
        fe = self.fe
        if fe is None:
            return None
        v_in, i_l = fe.measurement()
        return PfcSample(self.step, self.time, v_in, i_l, self.dc.positive)

    def stored_energy(self) -> float:
        """J: motor magnetic + capacitors + kinetic (+ front-end inductors and filter capacitors)."""
        e = K.stored_energy(self.st, self.dc.x, self._prm)
        if self.fe is not None:
            e += self.fe.stored_energy()
        return e

    def energy_input(self) -> float:
        """J delivered into the plant: the grid with the front end, else the DC source."""
        return self.fe.energy.grid if self.fe is not None else self.dc.energy_source

    def state(self) -> PlantStateSample:
        """Ground truth at t_k (numeric fields: plant_kernel.state_values; terminal voltages with
        the legs applied at the end of [t_k - T_s, t_k))."""
        K.state_values(self._buf, self._lut, self._lut_psi, self._codes[self._legs])
        sv = self._sv.tolist()
        fe = self.fe
        if fe is not None:
            sv[K.SV_STORED] += fe.stored_energy()
            sv[K.SV_ES] = 0.0
        return state_sample(self.step, sv, self._applied, self.state_extras())

    def state_extras(self) -> dict:
        """PlantState's fields that the kernels do not hold: front end, protection, faults."""
        fe = self.fe
        if fe is not None:
            FK.front_end_values(fe.fp, fe.fx, self.time, self._fv)
            front = front_extras(self._fv.tolist())
        else:
            front = NO_FRONT_END
        return dict(front, protection=self.protection, safe_state=self.in_safe_state,
                    **fault_extras(self.faults))

    def energy_balance_error(self) -> float:
        """input - (stored - stored_0) - losses - mechanical output [J]."""
        en = self.energy
        fe_loss = self.fe.energy.losses if self.fe is not None else 0.0
        return (self.energy_input() - (self.stored_energy() - en.stored_initial)
                - en.copper - en.device - en.friction - en.mechanical - fe_loss)

    def _trip_level(self) -> float:
        """The peak-current level to locate (0 = none: disabled or already tripped)."""
        trip = self.trip
        return trip.level if (trip.enabled and not trip.tripped) else 0.0

    def advance(self) -> None:
        """Integrate one base tick with the latched commands (plant_kernel.advance_tick)."""
        fe = self.fe
        fp, fx = (fe.fp, fe.fx) if fe is not None else (K.NO_FRONT_END, K.NO_FRONT_END)
        target = self._off_code if self.in_safe_state else self._codes[self._commanded]
        n_ev, code = K.advance_tick(self._buf, self._lut, self._ev, self.time, self._trip_level(),
                                    self._codes[self._legs], target, self._off_code, fp, fx)
        self.finish_ticks(self.step + 1, code, self._ev[:min(n_ev, len(self._ev))].tolist())

    def finish_ticks(self, step: int, code: int | None = None, events=()) -> None:
        """After compiled ticks up to tick step: applied legs (leg code), located events (when, kind,
        phase, current[, tick]) acted on in order, the clock."""
        if code is not None:
            self._legs = self._legs_of_code[code]
        last = self.step
        for row in events:
            self.step = int(row[4]) if len(row) > 4 else last
            self._record_event(row[0], int(row[1]), int(row[2]), row[3])
        self._applied = self._switches_of[self._legs]
        self.step = step
        self.time = step * self.base_tick

    def commanded_code(self, switch_on: tuple | None = None) -> int:
        """Leg code of a gate command (None: of the one latched now); shoot-through is not checked."""
        return self._codes[self._commanded if switch_on is None else self._legs_of[switch_on][0]]

    def _record_event(self, when: float, kind: int, q: int, current: float) -> None:
        """Act on and log an event (plant_kernel EV_*, or a front-end event) at sim time when [s]."""
        if kind >= FK.EV_FRONT_END:
            self.fe.take_event(when, kind, current)
            return
        if kind == K.EV_LIMIT:
            log_event(self.events, when, 'event limit: rest of step not split')
        elif kind == K.EV_TRIP:
            self.trip.trip(when, current)
            self._legs = self.inverter.all_off()
            log_event(self.events, when, f'trip phase {"abc"[q]}')
            self.faults.record(FaultKind.MOTOR_OVER_CURRENT, when, self.step,
                               f'motor peak-current trip: phase {"abc"[q]} current '
                               f'{current:.3f} A reached {self.trip.level:g} A: all switches off, safe state '
                               'until plant/reset_protection',
                               phase='abc'[q], current=f'{current:.6f}')
        else:
            log_event(self.events, when, f'current zero phase {"abc"[q]}')
