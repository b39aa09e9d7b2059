"""Runs a headless co-simulation in compiled chunks (:mod:`.cosim_kernel`) where it applies.

:class:`FusedDtcLoop` is the ``fused`` runner of :class:`bldc_plant_sim.core.cosim.CoSimulation`
for the DTC core with a compiled mode, or a controller answering every sample with the same
gates (``constant_gates``), with noise-free sensors and no shoot-through command; a pending DTC
reconfiguration and everything else run per sample. The trajectory is bit-identical to the
per-sample path; records are kept as arrays (:class:`~bldc_plant_sim.core.cosim.RecordBlock`).
It works on the plant's and the schedule's internals as their own per-sample code does.
"""
from __future__ import annotations

import copy

import numpy as np

from bldc_plant_sim.core import front_end_kernel as FK
from bldc_plant_sim.core import plant_kernel as PK
from bldc_plant_sim.core.cosim import FrontRecords, RecordBlock
from bldc_plant_sim.core.lockstep import ControllerKind
from bldc_plant_sim.core.plant import BOOST_FAULTS, fault_extras
from drive_common.samples import GateSample
from dtc_controller.core.controller import DtcCore
from pfc_controller.core.average_current_control import O_SIZE, PfcCore, samples_of

from . import cosim_kernel as F

CHUNK_RECORDS = 16384      # records per chunk (a block's arrays)


class FusedDtcLoop:
    """``chunk(cosim, steps)``: up to steps ticks compiled, or 0 when the tick needs Python."""

    def __init__(self, chunk_records: int = CHUNK_RECORDS) -> None:
        self.chunk_records = int(chunk_records)
        self._events = None

    @staticmethod
    def controller(cosim):
        """The controller of cosim as the loop runs it (_ModeRun / _ConstantRun), or None."""
        plant, dtc, pfc = cosim.plant, cosim.dtc, cosim.pfc
        if (plant.sensors.draws or getattr(dtc, 'topology', None) != plant.topology
                or (pfc is not None and (type(pfc) is not PfcCore or plant.fe is None))
                or (pfc is None and cosim.schedule.pfc_ticks)):
            return None
        if type(dtc) is DtcCore and dtc._pending is None and hasattr(dtc.mode, 'fused_arrays'):
            run = _ModeRun(dtc.mode)
        elif getattr(dtc, 'constant_gates', None) is not None:
            run = _ConstantRun(tuple(dtc.constant_gates))
        else:
            return None
        commands = [*run.commands, cosim.schedule._held[ControllerKind.GATE]]
        return None if any(plant.inverter.shoot_through_legs(sw) for sw in commands) else run

    def chunk(self, cosim, steps: int) -> int:
        """Run up to steps ticks in one compiled call; the ticks done (0: not applicable)."""
        run = self.controller(cosim) if steps > 0 else None
        if run is None:
            return 0
        plant, sched = cosim.plant, cosim.schedule
        every = cosim.record_every
        n_rec = min(self.chunk_records, steps // every + 1) if every else 1
        ev_rows = len(plant._ev)
        if self._events is None or len(self._events) < 4 * ev_rows:
            self._events = np.zeros((max(16384, 4 * ev_rows), 5))
        held = sched._held[ControllerKind.GATE]
        cmd_codes = np.array([plant.commanded_code(sw) for sw in run.commands]
                             + [plant.commanded_code(held), plant.commanded_code()], dtype=np.int64)
        loop = np.zeros(F.L_SIZE, dtype=np.int64)
        nc = len(run.commands)
        loop[F.L_LEGS], loop[F.L_CMD], loop[F.L_HELD] = plant._codes[plant._legs], nc + 1, nc
        out = np.zeros(max(run.out_size, 18))
        rec_step = np.zeros(n_rec, np.int64)
        rec_sv = np.zeros((n_rec, PK.SV_SIZE))
        rec_x = np.zeros((n_rec, F.X_SIZE))
        rec_out = np.zeros((n_rec, run.out_size))
        front = _FrontRun(cosim, n_rec if every else 1)
        consts = np.array([plant.base_tick, plant._trip_level(), plant._off_code, float(plant.in_safe_state),
                           run.encoder_offset, float(bool(plant._safe)), plant.protection_outside_front_end])
        sched_ = np.array([sched.dtc_ticks, sched.computation_delay, every, sched.pfc_ticks, front.n_avg], np.int64)
        extras, applied0, k0 = plant.state_extras(), plant._applied, plant.step
        F.run_chunk(steps, k0, sched_, consts, loop, plant._buf, plant._lut, plant._lut_psi, plant._ev,
                    plant.sensors.cfg, run.kind, run.arrays, out, cmd_codes, rec_step, rec_sv, rec_x, rec_out,
                    self._events, *front.arrays())
        events = self._events[:int(loop[F.L_EVENTS])].tolist()
        faults = _fault_changes(plant.faults, events) if plant.fe is not None else []
        self._finish(cosim, run, loop, held, events)
        front.finish(cosim)
        n = int(loop[F.L_RECORDS])
        if n:
            self._add_block(cosim, run, rec_step[:n], rec_sv[:n], rec_x[:n], rec_out[:n], extras, applied0, k0,
                            front.records(n, rec_x[:n], consts[F.C_PROTECTION], faults))
        return int(loop[F.L_TICKS])

    def _finish(self, cosim, run, loop, held, events) -> None:
        """The plant, the latch and the controller as the per-sample path leaves them."""
        plant, sched = cosim.plant, cosim.schedule
        commands = [*run.commands, held]
        h = int(loop[F.L_HELD])
        sched._held[ControllerKind.GATE] = commands[h]
        c = int(loop[F.L_CMD])
        if c < len(commands):
            plant.apply_gates(commands[c])
        plant.finish_ticks(plant.step + int(loop[F.L_TICKS]), int(loop[F.L_LEGS]), events)
        run.after()

    @staticmethod
    def _add_block(cosim, run, steps, sv, x, out, extras, applied0, k0, front) -> None:
        """The chunk's records as a RecordBlock of the trajectory."""
        plant = cosim.plant
        codes = x[:, F.X_LEGS].astype(np.int64)
        switches = {code: plant.inverter.switches(tuple(PK.legs_of_code(code).tolist()))
                    for code in np.unique(codes).tolist()}
        applied = list(map(switches.__getitem__, codes.tolist()))
        if int(steps[0]) == k0:
            applied[0] = applied0
        theta, speed = x[:, F.X_THETA], x[:, F.X_SPEED]
        status, columns = run.status_builder(out, theta, speed), run.columns(out, theta, speed)
        topology = plant.topology
        commands = run.commands

        def gate(step, r):
            return GateSample(step, topology, commands[int(out[r, 0])] if out.shape[1] else commands[0])

        cosim.trajectory.pop_last_if(int(steps[0]))
        cosim.trajectory.add_block(RecordBlock(steps, plant.base_tick, sv, applied, extras,
                                               x[:, F.X_DUE] != 0.0, status, gate, columns, front))


_NO_SPLIT, _NO_UPPER = np.zeros((1, 1, 1), np.int64), np.zeros((1, 1), np.int64)
_NO_PFC = (np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1))
# event-log kind of a boost trip -> its fault
_BOOST_TRIPS = {FK.EV_FRONT_END + FK.KIND_NAMES.index(name): fault for name, fault in BOOST_FAULTS.items()}


def _fault_changes(faults, events: list) -> list:
    """[(first step, PlantState fault fields)] after each boost trip among a chunk's events (rows
    when, kind, phase, value, tick): its fault counted on a copy of the plant's record, acting on
    the records from the next tick on (a motor trip ends the chunk)."""
    changes, shadow = [], None
    for when, kind, _, _, tick in events:
        fault = _BOOST_TRIPS.get(int(kind))
        if fault is not None:
            if shadow is None:
                shadow = copy.copy(faults)
                shadow.counts, shadow.pending = list(faults.counts), []
            shadow.record(fault, when, int(tick), '')
            changes.append((int(tick) + 1, fault_extras(shadow)))
    return changes


class _FrontRun:
    """The front end and PfcCore of a chunk: their arrays in, the duty latch out, the records."""

    def __init__(self, cosim, n_rec: int) -> None:
        plant, sched, pfc = cosim.plant, cosim.schedule, cosim.pfc
        fe = plant.fe
        self.fp, self.fx = (fe.fp, fe.fx) if fe is not None else (PK.NO_FRONT_END, PK.NO_FRONT_END)
        if pfc is not None:
            *self.pfc, self.n_avg, self.pfc_out = pfc.fused_arrays()
            self.pfc = tuple(self.pfc)
        else:
            self.pfc, self.n_avg, self.pfc_out = _NO_PFC, 0, np.zeros(O_SIZE)
        held_duty, held_on = sched._held[ControllerKind.DUTY]
        applied_duty, applied_on = plant._duty
        self.duty = np.array([held_duty, held_on, applied_duty, applied_on], dtype=float)
        self.rec_fe = np.zeros((n_rec if fe is not None else 1, FK.FV_SIZE))
        self.rec_pfc = np.zeros((n_rec if pfc is not None else 1, O_SIZE))
        self.present = fe is not None

    def arrays(self) -> tuple:
        """run_chunk's front-end arguments (fp, fx, pfc, n_avg, pfc_out, duty, rec_fe, rec_pfc)."""
        return self.fp, self.fx, self.pfc, self.n_avg, self.pfc_out, self.duty, self.rec_fe, self.rec_pfc

    def finish(self, cosim) -> None:
        """The duty latch (held and applied commands) as the per-sample path leaves it."""
        d = self.duty.tolist()
        cosim.schedule._held[ControllerKind.DUTY] = (d[F.D_HELD], d[F.D_HELD_ON] != 0.0)
        cosim.plant._duty = (d[F.D_APPLIED], d[F.D_APPLIED_ON] != 0.0)

    def records(self, n: int, x, protection: float, faults: list) -> FrontRecords | None:
        """The chunk's front-end records (None without the front end)."""
        if not self.present:
            return None
        rec_pfc = self.rec_pfc
        rows = []

        def row(r):
            if not rows:
                rows.append(rec_pfc.tolist())
            return rows[0][r]
        return FrontRecords(self.rec_fe[:n], int(protection), faults, x[:, F.X_PFC_DUE] != 0.0,
                            lambda step, r: samples_of(step, row(r))[1],
                            lambda step, r: samples_of(step, row(r))[0])


class _ModeRun:
    """A compiled DTC mode in the loop: its arrays, vectors as commands, status from the outputs."""

    def __init__(self, mode) -> None:
        self.mode = mode
        kind, prm, st, tab, coef, legs, select, split, upper = mode.fused_arrays()
        self.kind = kind
        self.arrays = (prm, st, tab, coef, legs, select, _NO_SPLIT if split is None else split,
                       _NO_UPPER if upper is None else upper)
        self.commands = [v.switch_on for v in mode.vectors]
        self.out_size = len(mode._out)
        self.encoder_offset = mode.encoder_offset

    def status_builder(self, out, theta, speed):
        mode, rotation = self.mode, self.mode.rotation
        rows = []

        def status(step, r):
            if not rows:                    # the block's outputs as Python floats, once
                rows.extend((out.tolist(), theta.tolist(), speed.tolist()))
            return mode.status_of(step, rotation, rows[0][r], rows[1][r], rows[2][r])
        return status

    def columns(self, out, theta, speed):
        mode, rotation = self.mode, self.mode.rotation
        return lambda steps, rows: mode.status_columns(steps, rotation, out[rows], theta[rows], speed[rows])

    def after(self) -> None:
        self.mode.after_fused()


class _ConstantRun:
    """A controller answering every sample with the same gates and no status."""

    kind = F.CONSTANT
    arrays = (np.zeros(1), np.zeros(1), np.zeros((1, 1)), np.zeros((1, 1)), _NO_UPPER, _NO_SPLIT,
              _NO_SPLIT, _NO_UPPER)
    out_size = 0
    encoder_offset = 0.0

    def __init__(self, switch_on: tuple) -> None:
        self.commands = [switch_on]

    def status_builder(self, out, theta, speed):
        return lambda step, r: None

    def columns(self, out, theta, speed):
        return lambda steps, rows: {}

    def after(self) -> None:
        pass
