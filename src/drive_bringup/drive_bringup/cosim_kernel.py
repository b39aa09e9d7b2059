"""The fused lockstep loop: plant (+ front end) + compiled DTC mode (+ PFC) for many base ticks in one call.

The tick of :meth:`bldc_plant_sim.core.cosim.CoSimulation.tick` (docs/architecture.md "Time and
lockstep") in compiled code, from the per-sample path's own functions, so the trajectories are
bit-identical: at a DTC-due tick the noise-free sensors, the mode's measurement and sample
(two- or three-phase kernel), the latch (``computation_delay``), a record every
``record_every`` ticks and the plant's tick; with the front end, the PFC sample, the duty latch
and the front end's PlantState fields. A peak-current trip ends the chunk after its tick
(Python records the fault); located events (boost trips among them) are returned with their tick.
"""
from __future__ import annotations

import numpy as np

from bldc_plant_sim.core import front_end_kernel as FK
from bldc_plant_sim.core import plant_kernel as PK
from bldc_plant_sim.core.link_kernel import DC_VL, DC_VU
from bldc_plant_sim.core.sensors import sense
from drive_common.compiled import njit
from dtc_controller.core.modes import three_phase_kernel as K3
from dtc_controller.core.modes import two_phase_kernel as K2
from dtc_controller.core.modes.regulation import measure_values
from pfc_controller.core.average_current_control import O_DUTY, O_SWITCH, pfc_step

CONSTANT, TWO_PHASE, THREE_PHASE = 0, 2, 3     # the controller: same gates always, DTC modes
# per-record extras: measured encoder angle, measured speed, DTC due (0/1), applied leg code, PFC due
X_THETA, X_SPEED, X_DUE, X_LEGS, X_PFC_DUE, X_SIZE = range(6)
# duty latch (float64): held duty and enable (computation_delay), applied duty and enable (plant)
D_HELD, D_HELD_ON, D_APPLIED, D_APPLIED_ON, D_SIZE = range(5)
# sched (int64): DTC ticks, computation delay, record every, PFC ticks, PFC average window
S_DTC, S_DELAY, S_EVERY, S_PFC, S_AVG_N = range(5)
# consts: tick [s], trip level [A], all-off leg code, safe (0/1), encoder offset, safe-state reasons
# (0/1: the boost held off), motor and safe-state protection bits
C_TICK, C_LEVEL, C_OFF, C_SAFE, C_ENC, C_SAFE_REASONS, C_PROTECTION, C_SIZE = range(8)
# loop state (int64): leg code applied, commanded command, held command, records, events, ticks
L_LEGS, L_CMD, L_HELD, L_RECORDS, L_EVENTS, L_TICKS, L_SIZE = range(7)


@njit
def dtc_sample(kind, scfg, buf, dtc, enc_offset, out, noise):
    """Sensors, measurement and one DTC sample of the mode arrays dtc; returns (theta, speed)."""
    prm, st, tab, coef, legs, select, split, upper = dtc
    i0, i1, i2 = buf[PK.B_ST + PK.ST_I], buf[PK.B_ST + PK.ST_I + 1], buf[PK.B_ST + PK.ST_I + 2]
    v_up, v_lo = buf[PK.B_DC + PK.DC_VU], buf[PK.B_DC + PK.DC_VL]
    ia, ib, ic, vdc, vm, w, count, angle = sense(scfg, i0, i1, i2, v_up + v_lo, v_lo,
                                                 buf[PK.B_ST + PK.ST_TH], buf[PK.B_ST + PK.ST_W], noise)
    i_a, i_b, i_c, i_al, i_be, theta, v_dc, v_mid = measure_values(ia, ib, ic, angle, enc_offset, vdc, vm)
    if kind == TWO_PHASE:
        K2.two_phase_step(prm, st, tab, coef, legs, select, split, i_a, i_b, i_c, i_al, i_be, theta,
                          v_dc, v_mid, w, out)
    else:
        K3.three_phase_step(prm, st, tab, coef, legs, upper, select, i_a, i_b, i_c, i_al, i_be, theta,
                            v_dc, v_mid, w, out)
    return theta, w


@njit
def record(buf, lut, lut_psi, loop, k, due, theta, w, out, rec_step, rec_sv, rec_x, rec_out):
    """One record at tick k: state values, the DTC output (if due) and the extras (X_*)."""
    r = loop[L_RECORDS]
    PK.state_values(buf, lut, lut_psi, loop[L_LEGS])
    rec_step[r] = k
    rec_sv[r, :] = buf[PK.B_SV:PK.B_RES]
    rec_x[r, X_THETA], rec_x[r, X_SPEED], rec_x[r, X_DUE], rec_x[r, X_LEGS] = theta, w, due, loop[L_LEGS]
    if due and rec_out.shape[1]:
        rec_out[r, :] = out[:rec_out.shape[1]]
    loop[L_RECORDS] = r + 1


@njit
def record_front_end(fp, fx, r, t, pfc_due, pfc_out, rec_sv, rec_x, rec_fe, rec_pfc):
    """The front end's part of record r at plant time t (PlantCore.state: its stored energy
    added, no DC-source energy) and the PFC output if due."""
    fv = rec_fe[r]
    FK.front_end_values(fp, fx, t, fv)
    rec_sv[r, PK.SV_STORED] += fv[FK.FV_STORED]
    rec_sv[r, PK.SV_ES] = 0.0
    rec_x[r, X_PFC_DUE] = pfc_due
    if pfc_due:
        rec_pfc[r, :] = pfc_out


@njit
def pfc_sample(fp, fx, buf, pfc_prm, pfc_st, pfc_buf, pfc_avg, n_avg, pfc_out, duty, delay, safe_reasons):
    """The PFC's sample (rectified voltage, link voltage, i_L sensed as PlantCore.pfc_sample) and
    its duty latched as LockstepSchedule.latch / PlantCore.apply_duty / FrontEnd.set_duty."""
    v_o = buf[PK.B_DC + DC_VU] + buf[PK.B_DC + DC_VL]
    pfc_step(pfc_prm, pfc_st, pfc_buf, pfc_avg, n_avg, FK.rectified_voltage(fp, fx), v_o, fx[FK.FX_IL],
             pfc_out)
    d, on = pfc_out[O_DUTY], pfc_out[O_SWITCH] != 0.0
    if delay:
        d, on, duty[D_HELD], duty[D_HELD_ON] = duty[D_HELD], duty[D_HELD_ON] != 0.0, d, 1.0 if on else 0.0
    duty[D_APPLIED], duty[D_APPLIED_ON] = unit_clamp(d), 1.0 if on else 0.0
    if safe_reasons:
        fx[FK.FX_DUTY], fx[FK.FX_ENABLE] = 0.0, 0.0
    else:
        fx[FK.FX_DUTY], fx[FK.FX_ENABLE] = unit_clamp(duty[D_APPLIED]), duty[D_APPLIED_ON]


@njit
def unit_clamp(d):
    """Python's min(1.0, max(0.0, d)) (ties and NaN keep the bound: 0.0, never -0.0)."""
    x = d if d > 0.0 else 0.0
    return x if x < 1.0 else 1.0


@njit
def keep_events(ev, n_ev, k, events, loop):
    """Append a tick's located events (when, kind, phase, current) with the tick to events;
    True when one is a motor trip (boost trips only open the boost switch: the chunk goes on)."""
    tripped = False
    n = loop[L_EVENTS]
    for e in range(min(n_ev, ev.shape[0])):
        events[n, :4] = ev[e]
        events[n, 4] = k
        n += 1
        tripped = tripped or int(ev[e, 1]) == PK.EV_TRIP
    loop[L_EVENTS] = n
    return tripped


@njit
def run_chunk(n, k0, sched, consts, loop, buf, lut, lut_psi, ev, scfg, kind, dtc, out, cmd_codes,
              rec_step, rec_sv, rec_x, rec_out, events, fp, fx, pfc, n_avg, pfc_out, duty, rec_fe, rec_pfc):
    """Up to n base ticks from tick k0 (module doc). sched (S_*), consts (C_*); loop (L_*) in/out;
    cmd_codes: commanded leg code of each command (mode vectors, then the command held at the
    start). With a front end (fp, fx not empty; else plant_kernel.NO_FRONT_END): pfc (parameters,
    loop state, average ring and state of PfcCore) due every S_PFC ticks (0: none), duty (D_*)
    in/out, rec_fe / rec_pfc its records. Stops early after a trip or when the record / event
    buffers might not hold one more tick."""
    dtc_ticks, delay, every, pfc_ticks = sched[S_DTC], sched[S_DELAY], sched[S_EVERY], sched[S_PFC]
    tick, level, off_code, safe, enc_offset = (consts[C_TICK], consts[C_LEVEL], int(consts[C_OFF]),
                                               consts[C_SAFE], consts[C_ENC])
    front_end = fp.shape[0] != 0
    noise = np.zeros(6)
    theta = w = np.nan
    legs, target = PK.legs_of_code(loop[L_LEGS]), np.empty(3, np.int64)
    all_off = PK.legs_of_code(off_code)
    for j in range(n):
        k = k0 + j
        due = dtc_ticks > 0 and k % dtc_ticks == 0
        if due:
            vector = 0
            if kind != CONSTANT:
                theta, w = dtc_sample(kind, scfg, buf, dtc, enc_offset, out, noise)
                vector = int(out[0])
            if delay:
                loop[L_CMD], loop[L_HELD] = loop[L_HELD], vector
            else:
                loop[L_CMD] = vector
        pfc_due = front_end and pfc_ticks > 0 and k % pfc_ticks == 0
        if pfc_due:
            pfc_sample(fp, fx, buf, pfc[0], pfc[1], pfc[2], pfc[3], n_avg, pfc_out, duty, delay,
                       consts[C_SAFE_REASONS] != 0.0)
        if every and k % every == 0:
            record(buf, lut, lut_psi, loop, k, due, theta, w, out, rec_step, rec_sv, rec_x, rec_out)
            if front_end:
                record_front_end(fp, fx, loop[L_RECORDS] - 1, k * tick, pfc_due, pfc_out, rec_sv, rec_x,
                                 rec_fe, rec_pfc)
        PK.legs_into(off_code if safe else cmd_codes[loop[L_CMD]], target)
        n_ev = PK.advance_legs(buf, lut, ev, k * tick, level, legs, target, all_off, fp, fx)
        loop[L_LEGS] = PK.code_of(legs)
        loop[L_TICKS] = j + 1
        if n_ev and keep_events(ev, n_ev, k, events, loop):
            break
        if loop[L_RECORDS] >= rec_step.shape[0] or loop[L_EVENTS] + ev.shape[0] > events.shape[0]:
            break
