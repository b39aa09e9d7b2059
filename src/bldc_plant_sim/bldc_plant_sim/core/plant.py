"""PlantCore: motor + inverter + DC link + load + sensors + protection, stepped per base tick.

Integration (docs/architecture.md "The plant"): between events the circuit is linear with
constant sources. Over a segment of length T the back-EMFs are held at the
segment's mid angle (predicted with the last acceleration), device drops at
their segment-start values and the DC-link voltages at their start values;
every conducting phase then follows the exact exponential

    i_x(t) = i_ss + (i_x0 - i_ss) exp(-t R/(L - M)),  i_ss = (u_x - v_n)/R,

(v_n = mean of u over the conducting phases, see :mod:`.inverter`), one
segment per inner step when nothing happens. Events inside a step are
located analytically on that exponential and the step is split there:
- a diode (or a threshold device) current reaching zero: the phase becomes a
  true open phase (current exactly 0.0) until it is forward-biased again;
- a phase current reaching the peak-current trip level: all switches open
  at that instant and stay open until reset;
- the end of the inverter dead time after a gate change.

Energies are integrated with the exact integrals of i and i^2 over each
segment: source (DC link), copper R int i^2, device sum v_f int i, friction,
load work; stored = (L - M)/2 sum i^2 + capacitors + J w^2 / 2. The balance
input = stored - stored_0 + losses + mechanical output then closes to the
error of the mid-segment EMF prediction (second order in the step).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from drive_common.parameters import ParameterError
from drive_common.samples import ALL_OFF, DriveSample, PfcSample

from ..parameters import PLANT_SCHEMA, effective_params
from .dc_link import DcLink
from .faults import FaultKind, FaultRecord
from .front_end import FrontEnd
from .inverter import MIDPOINT, OFF, RAIL_M, RAIL_P, Inverter
from .load import LoadMachine
from .motor import Motor
from .protection import MOTOR_OVER_CURRENT, SHOOT_THROUGH, PeakCurrentTrip
from .sensors import Sensors

TWO_PI = 2.0 * math.pi
NAN = math.nan
_MAX_EVENTS_PER_STEP = 64


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


@dataclass
class EnergyLedger:
    """Cumulative losses and work since start [J] (the source energy is kept by the DC link)."""

    copper: float = 0.0
    device: float = 0.0
    friction: float = 0.0
    mechanical: float = 0.0
    stored_initial: float = 0.0     # stored energy at start (moved when a part is rebuilt)


class PlantCore:
    """The plant of docs/architecture.md "The plant" without ROS (API: "Core APIs").

    params: a parameter snapshot of PLANT_SCHEMA (missing names take
    their defaults). With ``motor.file`` the file gives the motor's values and
    explicit parameters override it (:func:`~bldc_plant_sim.parameters.effective_params`);
    ``params`` holds the values actually used.
    """

    def __init__(self, params: dict | None = None) -> None:
        p = self.validate(params or {})
        self._requested = PLANT_SCHEMA.validate_changes(PLANT_SCHEMA.defaults(),
                                                             params or {}, running=False)
        self.params = p
        self.base_tick = p['base_tick']
        self.step = 0
        self.time = 0.0
        self.motor = Motor.from_params(p)
        self.inverter = Inverter.from_params(p)
        self.topology = self.inverter.topology
        self.dc = DcLink.from_params(p)
        self.faults = FaultRecord()   # every fault counted, the first latched (core/faults.py)
        self.fe = self._attach(FrontEnd.from_params(p)) if p['front_end.enabled'] else None
        self.shoot_through_policy = p['inverter.shoot_through']
        self.load = LoadMachine.from_params(p)
        self.sensors = Sensors(p, self.motor.pole_pairs)
        self.trip = PeakCurrentTrip(p['protection.peak_current'])
        self._derive_constants(p['integration.max_step'])
        # State.
        self.i = [0.0, 0.0, 0.0]
        self.theta_m = p['motor.initial_angle']
        self.omega = p['motor.initial_speed']
        if self.load.dynamometer:
            self.omega = self.load.speed
        self.accel = 0.0
        self._count0 = self.sensors.encoder_count(self.theta_m)
        self._t_load = self.load.load_torque(self.omega)
        self._safe = 0
        self._commanded = self.inverter.all_off()
        self._legs = self._commanded
        self._applied = ALL_OFF
        self._duty = (0.0, False)
        self._elapsed = 0.0
        self.events: list[tuple[float, str]] = []   # (time, what) of located events, bounded
        self.energy = EnergyLedger()
        self.energy.stored_initial = self.stored_energy()

    # ------------------------------------------------------------------ parameters
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
        """The values this plant would use for a new requested snapshot (validate() relative to
        the snapshot it runs on), refusing what it cannot take (a new base tick after t = 0)."""
        if hasattr(self, 'params'):
            snap = self.validate(params, self._requested, self.params)
        else:
            snap = self.validate(params)
        if getattr(self, 'step', 0) > 0 and snap['base_tick'] != self.base_tick:
            raise ParameterError(f"base_tick: cannot change from {self.base_tick} s after the "
                                 'simulation started')
        if getattr(self, 'step', 0) > 0 and snap['front_end.enabled'] != self.params['front_end.enabled']:
            raise ParameterError('front_end.enabled: cannot change after the simulation started '
                                 '(the energy ledger would lose its input)')
        return snap

    def reconfigure(self, params: dict) -> None:
        """Apply a new snapshot at a sample boundary; the state (currents, rotor, time) is kept.

        Runtime parameters update in place; changed held parameters (allowed by
        the node only while the simulation is held) rebuild the affected part.
        The stored-energy baseline moves with a rebuilt part so the balance stays closed.
        """
        p = self.check_params(params)
        requested = PLANT_SCHEMA.validate_changes(PLANT_SCHEMA.defaults(), params,
                                                       running=False)
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
        fe.energy = old.energy
        fe.events, fe.event_counts = old.events, old.event_counts
        return self._attach(fe)

    def _attach(self, fe: FrontEnd) -> FrontEnd:
        """Route the front end's protection trips into the fault record."""
        fe.on_protection = self._boost_protection
        return fe

    def _boost_protection(self, kind: str, when: float, text: str) -> None:
        self.faults.record(FaultKind.BOOST_OVER_CURRENT if kind == 'over_current'
                           else FaultKind.BOOST_OVER_VOLTAGE, when, self.step, text)

    def _derive_constants(self, max_step: float) -> None:
        self._legs_of: dict = {}        # gate tuple -> (leg codes, shoot-through legs) (memo)
        self._switches_of: dict = {}    # leg codes -> applied gate tuple
        inv = self.inverter
        self._can_open = inv.v_ce + inv.v_d > 0.0   # switched legs have a blocking band at i = 0
        self._substeps = max(1, math.ceil(self.base_tick / max_step - 1e-9))
        self._h = self.base_tick / self._substeps
        m = self.motor
        self._R = m.resistance
        self._tau = m.time_constant
        self._a_h = math.exp(-self._h / self._tau)

    def step_of(self, time: float) -> int:
        """Base tick index at sim time [s] (rounded to the nearest tick)."""
        return int(round(time / self.base_tick))

    # ------------------------------------------------------------------ commands
    def apply_gates(self, switch_on: tuple) -> None:
        """Latch SW1..SW6 until the next call (forced off by safe state or trip).

        Both switches of a leg on (shoot-through) is a fault: recorded with the
        legs, and with ``inverter.shoot_through`` = safe_state (default) the plant
        enters the safe state until reset_protection(); with ``interlock`` the
        leg is turned off (the gate driver's interlock) and the run goes on.
        """
        memo = self._legs_of.get(switch_on)
        if memo is None:
            memo = self._legs_of[tuple(switch_on)] = (self.inverter.legs(switch_on),
                                                      self.inverter.shoot_through_legs(switch_on))
        self._commanded, shorted = memo
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
            if self._safe:
                self.fe.set_duty(0.0, False)
            else:
                self.fe.set_duty(*self._duty)

    def enter_safe_state(self, reason: int) -> None:
        """All switches off (boost off) until leave_safe_state(reason)."""
        self._safe |= int(reason)
        if self.fe is not None:
            self.fe.set_duty(0.0, False)

    def leave_safe_state(self, reason: int) -> None:
        """Clear one reason; the inverter and the boost take the latched commands again."""
        was_safe = self.in_safe_state
        self._safe &= ~int(reason)
        if self.fe is not None and not self._safe:
            self.fe.set_duty(*self._duty)
        self._note_safe_state_exit(was_safe)

    @property
    def in_safe_state(self) -> bool:
        """PlantState.safe_state: a safe-state reason or the latched motor trip."""
        return bool(self._safe or self.trip.tripped)

    def _note_safe_state_exit(self, was_safe: bool) -> None:
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
        if fe is not None and not self._safe:
            fe.set_duty(*self._duty)
        self._note_safe_state_exit(was_safe)
        return ok, text

    @property
    def protection(self) -> int:
        """PlantState PROTECTION_* bits: motor trip, boost over-current / over-voltage, safe state."""
        bits = (MOTOR_OVER_CURRENT if self.trip.tripped else 0) | self._safe
        if self.fe is not None:
            bits |= self.fe.protection
        return bits

    def _effective_legs(self) -> tuple:
        if self._safe or self.trip.tripped:
            return self.inverter.all_off()
        return self._commanded

    # ------------------------------------------------------------------ samples
    def drive_sample(self) -> DriveSample:
        """Sensed drive quantities at t_k."""
        m = self.motor
        theta_e = m.pole_pairs * self.theta_m
        return self.sensors.sample(self.step, self.time, self.i, self.dc.positive, self.dc.v_lower,
                                   self.theta_m, self._count0, self.omega,
                                   m.backemf.hall_code(theta_e))

    def pfc_sample(self) -> PfcSample | None:
        """Sensed boost quantities at t_k (None without the front end)."""
        fe = self.fe
        if fe is None:
            return None
        v_in, i_l = fe.measurement()
        return PfcSample(self.step, self.time, v_in, i_l, self.dc.positive)

    def stored_energy(self) -> float:
        """J: motor magnetic + capacitors + kinetic (+ front-end inductors and filter capacitors)."""
        e = (self.motor.magnetic_energy(self.i) + self.dc.stored_energy()
             + 0.5 * self.motor.inertia * self.omega * self.omega)
        if self.fe is not None:
            e += self.fe.stored_energy()
        return e

    def energy_input(self) -> float:
        """J delivered into the plant: the grid with the front end, else the DC source."""
        return self.fe.energy.grid if self.fe is not None else self.dc.energy_source

    def state(self) -> PlantStateSample:
        """Ground truth at t_k."""
        m = self.motor
        p = m.pole_pairs
        theta_e = p * self.theta_m
        k = m.backemf.lookup(theta_e)
        we = p * self.omega
        e = (we * k[0], we * k[1], we * k[2])
        i = tuple(self.i)
        # terminal voltages with the legs applied at the end of [t_k - T_s, t_k)
        cond, u, vn, _ = self.inverter.resolve(self._legs, i, e, self.dc.positive, self.dc.v_lower)
        term = tuple(u[x] + e[x] if cond[x] else vn + e[x] for x in range(3))
        en = self.energy
        fe = self.fe
        if fe is not None:
            grid_v, grid_i = fe.grid_voltage(self.time), fe.grid_current
            rect_v, ind_i = fe.rectified_voltage, fe.i_L
            boost_duty, boost_on = fe.applied_duty, fe.switch_enabled
            e_grid, e_src, e_fe = fe.energy.grid, 0.0, fe.energy.losses
        else:
            grid_v = grid_i = rect_v = ind_i = NAN
            boost_duty, boost_on = 0.0, False
            e_grid, e_src, e_fe = 0.0, self.dc.energy_source, 0.0
        return PlantStateSample(
            step=self.step, phase_current=i, back_emf=e, flux_linkage=m.flux_linkages(theta_e, i),
            terminal_voltage=term, neutral_voltage=vn,
            electromagnetic_torque=p * (k[0] * i[0] + k[1] * i[1] + k[2] * i[2]),
            load_torque=self._t_load, rotor_angle=theta_e % TWO_PI, mechanical_angle=self.theta_m,
            mechanical_speed=self.omega, dc_link_voltage=self.dc.positive,
            upper_capacitor_voltage=self.dc.v_upper, lower_capacitor_voltage=self.dc.v_lower,
            grid_voltage=grid_v, grid_current=grid_i, rectified_voltage=rect_v,
            inductor_current=ind_i,
            applied_switch_on=self._applied, boost_duty=boost_duty, boost_switch_enabled=boost_on,
            protection=self.protection, safe_state=self.in_safe_state,
            energy_grid_input=e_grid, energy_dc_source=e_src,
            energy_copper_loss=en.copper, energy_device_loss=en.device, energy_front_end_loss=e_fe,
            energy_friction_loss=en.friction, energy_mechanical_output=en.mechanical,
            energy_stored=self.stored_energy(),
            fault_count=self.faults.total, fault_counts=tuple(self.faults.counts),
            first_fault_kind=int(self.faults.first_kind), first_fault_time=self.faults.first_time)

    def energy_balance_error(self) -> float:
        """input - (stored - stored_0) - losses - mechanical output [J]."""
        en = self.energy
        fe_loss = self.fe.energy.losses if self.fe is not None else 0.0
        return (self.energy_input() - (self.stored_energy() - en.stored_initial)
                - en.copper - en.device - en.friction - en.mechanical - fe_loss)

    # ------------------------------------------------------------------ integration
    def advance(self) -> None:
        """Integrate one base tick with the latched commands."""
        legs = self._effective_legs()
        h = self._h
        n = self._substeps
        self._elapsed = 0.0
        dead = self.inverter.dead_time
        if dead > 0.0 and legs != self._legs:
            # The dead time covers k inner steps (k > 1 when it is longer than the step): it is
            # integrated in k equal pieces of at most h, then the rest of the k-th step, then
            # the n - k full steps: the integrated time is exactly n h = base_tick.
            k = min(n, max(1, math.ceil(dead / h - 1e-9)))
            self._legs = self.inverter.dead_time_legs(self._legs, legs)
            piece = dead / k
            for _ in range(k):
                self._integrate(piece)
            if self._legs != self._effective_legs():  # a trip inside the dead time wins
                legs = self._effective_legs()
            self._legs = legs
            self._integrate(k * h - dead)
            n -= k
        else:
            self._legs = legs
        for _ in range(n):
            self._integrate(h)
        applied = self._switches_of.get(self._legs)
        if applied is None:
            applied = self._switches_of[self._legs] = self.inverter.switches(self._legs)
        self._applied = applied
        self.step += 1
        self.time = self.step * self.base_tick

    def _integrate(self, dt: float) -> None:
        """Integrate dt [s], splitting at located events.

        A run of more than _MAX_EVENTS_PER_STEP events inside one step (a
        chattering circuit) finishes the step without further splitting and
        logs it, instead of stalling the time master.
        """
        remaining = dt
        events = 0
        while remaining > 1e-15:
            locate = events < _MAX_EVENTS_PER_STEP
            if not locate and events == _MAX_EVENTS_PER_STEP:
                self.events.append((self.time + self._elapsed, 'event limit: rest of step not split'))
            done = self._segment(remaining, remaining == self._h, locate)
            remaining -= done
            self._elapsed += done
            events += 1

    def _segment(self, T: float, nominal: bool, locate: bool = True) -> float:
        """One piecewise-linear segment of at most T [s]; returns the time integrated."""
        m = self.motor
        p = m.pole_pairs
        w0 = self.omega
        th0 = self.theta_m
        # Back-EMF held at the predicted mid-segment angle and speed.
        w_mid = w0 + 0.5 * T * self.accel
        shape = m.backemf
        x = (p * (th0 + 0.5 * T * (w0 + 0.25 * T * self.accel)) * shape.lut_scale) % shape.points
        j = int(x)
        f = x - j
        ta, tb, tc = shape.lut_k
        ka = ta[j] + f * (ta[j + 1] - ta[j])
        kb = tb[j] + f * (tb[j + 1] - tb[j])
        kc = tc[j] + f * (tc[j + 1] - tc[j])
        we = p * w_mid
        e = (we * ka, we * kb, we * kc)
        i = self.i
        dc = self.dc
        if dc.stiff:
            vp, vm = dc.v_upper + dc.v_lower, dc.v_lower
        else:
            vp, vm = dc.segment_voltages(T)
        legs = self._legs
        cond, u, vn, rail = self.inverter.resolve(legs, i, e, vp, vm)
        R = self._R
        tau = self._tau
        if dc.mode == 'current_fed' and cond[0] + cond[1] + cond[2] >= 2:
            # Corrector: the link prediction above uses the previous segment's average node
            # currents, a first-order error when the legs just changed (a chopped 20 A phase
            # current on 135 uF: about 1 % of the energy). Predict again from this segment's
            # own average rail currents (exact integrals at the predicted voltages).
            w_avg = tau * (1.0 - (self._a_h if nominal else math.exp(-T / tau))) / T
            ip = im = 0.0
            for q in (0, 1, 2):
                if cond[q]:
                    r = rail[q]
                    if r == RAIL_P or r == RAIL_M:
                        s = (u[q] - vn) / R
                        avg = s + (i[q] - s) * w_avg
                        if r == RAIL_P:
                            ip += avg
                        else:
                            im += avg
            i_s = dc._i_s
            d_lo = 0.5 * T * (i_s - ip - im) / dc.c_lower
            vm = dc.v_lower + d_lo
            vp = dc.v_upper + 0.5 * T * (i_s - ip) / dc.c_upper + vm
            cond, u, vn, rail = self.inverter.resolve(legs, i, e, vp, vm)
        a = self._a_h if nominal else math.exp(-T / tau)
        n_cond = cond[0] + cond[1] + cond[2]
        event = None
        if n_cond >= 2:
            iss = [(u[0] - vn) / R, (u[1] - vn) / R, (u[2] - vn) / R]
            i1 = [iss[0] + (i[0] - iss[0]) * a if cond[0] else 0.0,
                  iss[1] + (i[1] - iss[1]) * a if cond[1] else 0.0,
                  iss[2] + (i[2] - iss[2]) * a if cond[2] else 0.0]
            # Events: zero crossings of phases that can extinguish, and the trip level.
            t_event = T
            can_open = self._can_open
            trip = self.trip
            level = trip.level if (trip.enabled and not trip.tripped) else 0.0
            for q in (0, 1, 2):
                if not cond[q] or not locate:
                    continue
                i0q, i1q = i[q], i1[q]
                if i0q * i1q < 0.0 and legs[q] != MIDPOINT and (can_open or legs[q] == OFF):
                    c = i0q - iss[q]
                    t = -tau * math.log(-iss[q] / c)
                    if t < t_event:
                        t_event, event = t, ('zero', q)
                if level and abs(i1q) >= level:
                    target = level if i1q > 0.0 else -level
                    c = i0q - iss[q]
                    ratio = (target - iss[q]) / c if c != 0.0 else 0.0
                    t = -tau * math.log(ratio) if ratio > 0.0 and abs(i0q) < level else 0.0
                    if t < t_event or (event is not None and event[0] == 'zero' and t <= t_event):
                        t_event, event = t, ('trip', q)
            if event is not None:
                T = max(0.0, min(t_event, T))
                a = math.exp(-T / tau)
                i1 = [iss[q] + (i[q] - iss[q]) * a if cond[q] else 0.0 for q in (0, 1, 2)]
                if event[0] == 'zero':
                    q = event[1]
                    i1[q] = 0.0
                    if n_cond == 2:
                        i1 = [0.0, 0.0, 0.0]
            # Exact integrals of i and i^2 over the segment.
            one_a = 1.0 - a
            g1 = tau * one_a
            g2 = 0.5 * tau * (1.0 - a * a)
            q_int = [0.0, 0.0, 0.0]
            sq = 0.0
            dev = 0.0
            q_p = 0.0
            q_m = 0.0
            for q in (0, 1, 2):
                if cond[q]:
                    s = iss[q]
                    c = i[q] - s
                    qi = s * T + c * g1
                    q_int[q] = qi
                    sq += s * s * T + 2.0 * s * c * g1 + c * c * g2
                    r = rail[q]
                    v_ideal = vp if r == RAIL_P else vm if r == RAIL_M else 0.0
                    dev += (v_ideal - u[q] - e[q]) * qi
                    if r == RAIL_P:
                        q_p += qi
                    elif r == RAIL_M:
                        q_m += qi
            # Keep the star-point constraint exact after rounding.
            if n_cond == 3:
                b0, b1, b2 = abs(i1[0]), abs(i1[1]), abs(i1[2])
                if b0 >= b1 and b0 >= b2:
                    i1[0] = -(i1[1] + i1[2])
                elif b1 >= b2:
                    i1[1] = -(i1[0] + i1[2])
                else:
                    i1[2] = -(i1[0] + i1[1])
            elif cond[0]:
                if cond[1]:
                    i1[1] = -i1[0]
                else:
                    i1[2] = -i1[0]
            else:
                i1[2] = -i1[1]
            en = self.energy
            en.copper += R * sq
            en.device += dev
            if dc.stiff:
                dc.energy_source += vp * q_p + vm * q_m
            elif T > 0.0:
                self._draw_link(T, vp, q_p, q_m)
            te = p * (ka * q_int[0] + kb * q_int[1] + kc * q_int[2]) / T if T > 0.0 else 0.0
            self.i = i1
        else:
            te = 0.0
            if i[0] or i[1] or i[2]:
                self.i = [0.0, 0.0, 0.0]
            if T > 0.0 and dc.mode == 'current_fed':
                self._draw_link(T, vp, 0.0, 0.0)
        if T > 0.0:
            w1, w_avg, t_load, e_fric, e_load = self.load.step(m.inertia, m.friction, w0, te, T)
            self.omega = w1
            self.theta_m = th0 + w_avg * T
            self.accel = (w1 - w0) / T
            self._t_load = t_load
            en = self.energy
            en.friction += e_fric
            en.mechanical += e_load
        if event is not None:
            self._record_event(T, event)
        return T

    def _draw_link(self, T: float, vp: float, q_p: float, q_m: float) -> None:
        """Advance the soft DC link over the segment [t0, t0 + T): the front end (if any) sets the
        source current at link voltage vp, the inverter draws q_p / q_m [C] from the rails."""
        dc = self.dc
        t0 = self.time + self._elapsed
        if self.fe is not None:
            dc.source_current = self.fe.advance(t0, T, vp) / T
        dc.draw(q_p, q_m, T, t0)

    def _record_event(self, T: float, event: tuple) -> None:
        """Act on and log an event located at the end of the segment just integrated."""
        kind, q = event
        when = self.time + self._elapsed + T
        if len(self.events) > 10000:
            del self.events[:5000]
        if kind == 'trip':
            self.trip.trip(when, self.i[q])
            self._legs = self.inverter.all_off()
            self.events.append((when, f'trip phase {"abc"[q]}'))
            self.faults.record(FaultKind.MOTOR_OVER_CURRENT, when, self.step,
                               f'motor peak-current trip: phase {"abc"[q]} current '
                               f'{self.i[q]:.3f} A reached {self.trip.level:g} A: all switches off, safe state '
                               'until plant/reset_protection',
                               phase='abc'[q], current=f'{self.i[q]:.6f}')
        else:
            self.events.append((when, f'current zero phase {"abc"[q]}'))
