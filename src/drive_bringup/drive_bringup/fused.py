"""Runs a headless co-simulation in compiled chunks (:mod:`.cosim_kernel`) where it applies.

:class:`FusedDtcLoop` is the ``fused`` runner of :class:`bldc_plant_sim.core.cosim.CoSimulation`
for the DTC core with a compiled mode, no front end and no PFC, noise-free sensors and no
shoot-through vector; a pending DTC reconfiguration is applied by the per-sample path first
(it acts at the next DTC sample). Everything else (user controllers, the front end) runs per
sample. The trajectory is bit-identical to the per-sample path; records are kept as arrays
(:class:`~bldc_plant_sim.core.cosim.RecordBlock`) and objects built only when read.
"""
from __future__ import annotations

import numpy as np

from bldc_plant_sim.core import plant_kernel as PK
from bldc_plant_sim.core.cosim import RecordBlock
from bldc_plant_sim.core.lockstep import ControllerKind
from drive_common.samples import GateSample
from dtc_controller.core.controller import DtcCore

from . import cosim_kernel as F

CHUNK_RECORDS = 16384      # records per chunk (a block's arrays)


class FusedDtcLoop:
    """``chunk(cosim, steps)``: up to steps ticks compiled, or 0 when the tick needs Python."""

    def __init__(self, chunk_records: int = CHUNK_RECORDS) -> None:
        self.chunk_records = int(chunk_records)
        self._events = None

    @staticmethod
    def applies(cosim) -> bool:
        """The fused loop can run the next tick of cosim (module doc)."""
        plant, dtc = cosim.plant, cosim.dtc
        if (type(dtc) is not DtcCore or dtc._pending is not None or cosim.pfc is not None
                or plant.fe is not None or plant.sensors.draws or cosim.schedule.pfc_ticks):
            return False
        mode = dtc.mode
        if not hasattr(mode, 'fused_arrays') or dtc.topology != plant.topology:
            return False
        commands = [v.switch_on for v in mode.vectors] + [cosim.schedule._held[ControllerKind.GATE]]
        return not any(plant.inverter.shoot_through_legs(sw) for sw in commands)

    def chunk(self, cosim, steps: int) -> int:
        """Run up to steps ticks in one compiled call; the ticks done (0: not applicable)."""
        if steps <= 0 or not self.applies(cosim):
            return 0
        plant, mode, sched = cosim.plant, cosim.dtc.mode, cosim.schedule
        every = cosim.record_every
        n_rec = min(self.chunk_records, steps // every + 1) if every else 1
        ev_rows = len(plant._ev)
        if self._events is None or len(self._events) < 4 * ev_rows:
            self._events = np.zeros((max(4096, 4 * ev_rows), 5))
        vectors = mode.vectors
        held = sched._held[ControllerKind.GATE]
        cmd_codes = np.array([plant.commanded_code(v.switch_on) for v in vectors]
                             + [plant.commanded_code(held), plant.commanded_code()], dtype=np.int64)
        loop = np.zeros(F.L_SIZE, dtype=np.int64)
        loop[F.L_LEGS], loop[F.L_CMD], loop[F.L_HELD] = plant._code(plant._legs), len(vectors) + 1, len(vectors)
        kind, prm, st, tab, coef, legs, select, split, upper = mode.fused_arrays()
        dtc = (prm, st, tab, coef, legs, select,
               split if split is not None else np.zeros((1, 1, 1), np.int64),
               upper if upper is not None else np.zeros((1, 1), np.int64))
        out = np.zeros(max(len(mode._out), 18))
        rec_step = np.zeros(n_rec, np.int64)
        rec_sv = np.zeros((n_rec, PK.SV_SIZE))
        rec_x = np.zeros((n_rec, F.X_SIZE))
        rec_out = np.zeros((n_rec, len(mode._out)))
        consts = np.array([plant.base_tick, plant._trip_level(), plant._off_code,
                           float(plant.in_safe_state), mode.encoder_offset])
        extras, applied0, k0 = plant.state_extras(), plant._applied, plant.step
        F.run_chunk(steps, k0, np.array([sched.dtc_ticks, sched.computation_delay, every], np.int64),
                    consts, loop, plant._buf, plant._lut, plant._lut_psi, plant._ev, plant.sensors.cfg,
                    kind, dtc, out, cmd_codes, rec_step, rec_sv, rec_x, rec_out, self._events)
        done = int(loop[F.L_TICKS])
        self._finish(cosim, loop, cmd_codes, held)
        n = int(loop[F.L_RECORDS])
        if n:
            self._add_block(cosim, mode, rec_step[:n], rec_sv[:n], rec_x[:n], rec_out[:n], extras, applied0, k0)
        return done

    def _finish(self, cosim, loop, cmd_codes, held) -> None:
        """The plant, the latch and the mode as the per-sample path leaves them."""
        plant, mode, sched = cosim.plant, cosim.dtc.mode, cosim.schedule
        vectors = mode.vectors
        nv = len(vectors)
        h = int(loop[F.L_HELD])
        sched._held[ControllerKind.GATE] = vectors[h].switch_on if h < nv else held
        c = int(loop[F.L_CMD])
        if c < nv or c == nv:
            plant.apply_gates(vectors[c].switch_on if c < nv else held)
        plant.finish_ticks(plant.step + int(loop[F.L_TICKS]), int(loop[F.L_LEGS]),
                           self._events[:int(loop[F.L_EVENTS])].tolist())
        mode.after_fused()

    @staticmethod
    def _add_block(cosim, mode, steps, sv, x, out, extras, applied0, k0) -> None:
        """The chunk's records as a RecordBlock of the trajectory."""
        plant = cosim.plant
        switches = {}
        applied = []
        for r, code in enumerate(x[:, F.X_LEGS].astype(np.int64).tolist()):
            if r == 0 and steps[0] == k0:
                applied.append(applied0)
                continue
            sw = switches.get(code)
            if sw is None:
                sw = switches[code] = plant.inverter.switches(tuple(PK.legs_of_code(code).tolist()))
            applied.append(sw)
        rotation, topology = mode.rotation, plant.topology
        theta, speed = x[:, F.X_THETA], x[:, F.X_SPEED]

        def status(step, r):
            return mode.status_of(step, rotation, out[r].tolist(), float(theta[r]), float(speed[r]))

        def gate(step, r):
            return GateSample(step, topology, mode.vectors[int(out[r, 0])].switch_on)

        cosim.trajectory.pop_last_if(int(steps[0]))
        cosim.trajectory.add_block(RecordBlock(steps, plant.base_tick, sv, applied, extras,
                                               x[:, F.X_DUE] != 0.0, status, gate))
