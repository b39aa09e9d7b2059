"""Compiled per-sample work of :class:`~.plant.PlantCore` (docs/models.md "Integration of a base tick").

One float64 buffer the core owns (``B_*`` parts): ``st`` (``ST_*``: currents, shaft, ledger), the
DC link's and the load's ``x`` (:mod:`.link_kernel`), the parameters ``prm`` (``PR_*``), the state
values (``SV_*``) and one segment's results and scratch (``RS_*``, ``W_*``); ``lut``: the back-EMF
table (3 x (points + 1)). Entry points take the buffer and legs as one int (:func:`leg_code`):
numba's dispatch costs about 0.2 us per array argument. Compiled and ``NUMBA_DISABLE_JIT=1``
runs agree bit for bit.
"""
from __future__ import annotations

import math

import numpy as np

from drive_common.compiled import interpreted, njit

from . import front_end_kernel as FK
from .inverter import MIDPOINT, OFF, RAIL_M, RAIL_P, resolve_legs
from .link_kernel import (CURRENT_FED, DC_CL, DC_CU, DC_ES, DC_IS, DC_SIZE, DC_VL, DC_VU, IDEAL, LD_SIZE,
                          DC_SRC, link_draw, link_stored_energy, link_voltages, shaft_step)

# st slots
ST_I, ST_W, ST_TH, ST_ACC, ST_TL, ST_CU, ST_DEV, ST_FRIC, ST_MECH, ST_EL = 0, 3, 4, 5, 6, 7, 8, 9, 10, 11
ST_SIZE = 12
# prm slots
(PR_P, PR_SCALE, PR_POINTS, PR_R, PR_TAU, PR_AH, PR_H, PR_VCE, PR_VD, PR_RON, PR_J, PR_B,
 PR_CAN_OPEN, PR_DC, PR_DEAD, PR_N, PR_TICK, PR_LM) = range(18)
PR_SIZE = 18
# state_values slots (PlantState fields at t_k)
(SV_E, SV_PSI, SV_TERM, SV_VN, SV_TE, SV_ROTOR, SV_STORED, SV_VP, SV_VU, SV_VL, SV_ES, SV_CU, SV_DEV,
 SV_FRIC, SV_MECH, SV_TH, SV_W, SV_TL, SV_I) = (0, 3, 6, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20,
                                               21, 22, 23, 24)
SV_SIZE = 27
TWO_PI = 2.0 * math.pi
# PlantCore's one float64 buffer: st | DC link x | load x | prm | state values | segment results
B_ST = 0
B_DC = B_ST + ST_SIZE
B_LOAD = B_DC + DC_SIZE
B_PRM = B_LOAD + LD_SIZE
B_SV = B_PRM + PR_SIZE
B_RES = B_SV + SV_SIZE
# res slots (one segment's results), then the kernels' scratch arrays (W_*), so a tick
# allocates nothing
RS_TE, RS_VP, RS_QP, RS_QM, RS_KIND, RS_Q, RS_DRAW = range(7)
RS_SIZE = 7
W_K, W_E, W_U, W_COND, W_RAIL, W_ISS, W_I1, W_QINT, W_FLOAT = range(RS_SIZE, RS_SIZE + 27, 3)
W_BAND = RS_SIZE + 27
B_SIZE = B_RES + W_BAND + 12
EV_NONE, EV_ZERO, EV_TRIP, EV_LIMIT = 0, 1, 2, 3
MAX_EVENTS_PER_STEP = 64


@njit
def emf_at_mid(st, prm, lut, T):
    """k_abc at the predicted mid-segment angle and the mid-segment electrical speed."""
    w0, acc = st[ST_W], st[ST_ACC]
    w_mid = w0 + 0.5 * T * acc
    p = prm[PR_P]
    x = (p * (st[ST_TH] + 0.5 * T * (w0 + 0.25 * T * acc)) * prm[PR_SCALE]) % prm[PR_POINTS]
    j = int(x)
    f = x - j
    ka = lut[0, j] + f * (lut[0, j + 1] - lut[0, j])
    kb = lut[1, j] + f * (lut[1, j + 1] - lut[1, j])
    kc = lut[2, j] + f * (lut[2, j + 1] - lut[2, j])
    return ka, kb, kc, p * w_mid


@njit
def corrected_link_voltages(T, nominal, st, dcx, prm, cond, u, vn, rail):
    """Current-fed link: (V_P, V_M) predicted again from this segment's own average rail currents
    (the previous segment's are a first-order error right after a leg change)."""
    R, tau = prm[PR_R], prm[PR_TAU]
    w_avg = tau * (1.0 - (prm[PR_AH] if nominal else math.exp(-T / tau))) / T
    ip = im = 0.0
    for q in range(3):
        if cond[q]:
            r = rail[q]
            if r == RAIL_P or r == RAIL_M:
                s = (u[q] - vn) / R
                avg = s + (st[ST_I + q] - s) * w_avg
                if r == RAIL_P:
                    ip += avg
                else:
                    im += avg
    i_s = dcx[DC_IS]
    d_lo = 0.5 * T * (i_s - ip - im) / dcx[DC_CL]
    vm = dcx[DC_VL] + d_lo
    vp = dcx[DC_VU] + 0.5 * T * (i_s - ip) / dcx[DC_CU] + vm
    return vp, vm


@njit
def locate_event(T, st, prm, legs, cond, iss, i1, level):
    """(t_event, kind, phase) of the first current zero or trip level on the segment's
    exponentials (EV_NONE: none before T)."""
    tau = prm[PR_TAU]
    can_open = prm[PR_CAN_OPEN] != 0.0
    t_event, kind, phase = T, EV_NONE, -1
    for q in range(3):
        if not cond[q]:
            continue
        i0q, i1q = st[ST_I + q], i1[q]
        if i0q * i1q < 0.0 and legs[q] != MIDPOINT and (can_open or legs[q] == OFF):
            c = i0q - iss[q]
            t = -tau * math.log(-iss[q] / c)
            if t < t_event:
                t_event, kind, phase = t, EV_ZERO, q
        if level and abs(i1q) >= level:
            target = level if i1q > 0.0 else -level
            c = i0q - iss[q]
            ratio = (target - iss[q]) / c if c != 0.0 else 0.0
            t = -tau * math.log(ratio) if ratio > 0.0 and abs(i0q) < level else 0.0
            if t < t_event or (kind == EV_ZERO and t <= t_event):
                t_event, kind, phase = t, EV_TRIP, q
    return t_event, kind, phase


@njit
def keep_star_point(i1, cond, n_cond):
    """Sum of the phase currents exactly zero after rounding (the largest takes the rest)."""
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


@njit
def segment_integrals(T, a, st, prm, cond, iss, u, e, rail, vp, vm, q_int):
    """Exact segment integrals: charge per phase (q_int), R int i^2 and device loss [J], charges
    drawn from P and M [C]."""
    tau = prm[PR_TAU]
    g1 = tau * (1.0 - a)
    g2 = 0.5 * tau * (1.0 - a * a)
    sq = dev = q_p = q_m = 0.0
    for q in range(3):
        if cond[q]:
            s = iss[q]
            c = st[ST_I + q] - s
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
    return prm[PR_R] * sq, dev, q_p, q_m


@njit
def conducting_segment(T, nominal, locate, legs, st, dcx, prm, level, cond, u, vn, rail, vp, vm, e, k,
                       res):
    """Two or more phases conduct: exact exponentials over T (split at the first event) and the
    ledger; returns the time integrated."""
    R, tau = prm[PR_R], prm[PR_TAU]
    a = prm[PR_AH] if nominal else math.exp(-T / tau)
    n_cond = cond[0] + cond[1] + cond[2]
    iss = res[W_ISS:W_ISS + 3]
    i1 = res[W_I1:W_I1 + 3]
    i1[:] = 0.0
    for q in range(3):
        iss[q] = (u[q] - vn) / R
        if cond[q]:
            i1[q] = iss[q] + (st[ST_I + q] - iss[q]) * a
    kind, phase = EV_NONE, -1
    if locate:
        t_event, kind, phase = locate_event(T, st, prm, legs, cond, iss, i1, level)
    if kind != EV_NONE:
        T = max(0.0, min(t_event, T))
        a = math.exp(-T / tau)
        for q in range(3):
            i1[q] = iss[q] + (st[ST_I + q] - iss[q]) * a if cond[q] else 0.0
        if kind == EV_ZERO:
            i1[phase] = 0.0
            if n_cond == 2:
                i1[:] = 0.0
    q_int = res[W_QINT:W_QINT + 3]
    q_int[:] = 0.0
    copper, dev, q_p, q_m = segment_integrals(T, a, st, prm, cond, iss, u, e, rail, vp, vm, q_int)
    keep_star_point(i1, cond, n_cond)
    st[ST_CU] += copper
    st[ST_DEV] += dev
    res[RS_DRAW] = 0.0
    if prm[PR_DC] == IDEAL:
        dcx[DC_ES] += vp * q_p + vm * q_m
    elif T > 0.0:
        res[RS_DRAW] = 1.0
    res[RS_TE] = prm[PR_P] * (k[0] * q_int[0] + k[1] * q_int[1] + k[2] * q_int[2]) / T if T > 0.0 else 0.0
    res[RS_QP], res[RS_QM] = q_p, q_m
    res[RS_KIND], res[RS_Q] = kind, phase
    st[ST_I:ST_I + 3] = i1
    return T


@njit
def scratch_flags(res):
    """cond, u, rail (conduction flag, leg voltage, rail of each phase) in res's scratch, zeroed."""
    cond, u, rail = res[W_COND:W_COND + 3], res[W_U:W_U + 3], res[W_RAIL:W_RAIL + 3]
    cond[:] = 0.0
    u[:] = 0.0
    rail[:] = 0.0
    return cond, u, rail


@njit
def scratch_bands(res):
    """resolve_legs' band (3 x 4) and floating flags in res's scratch, zeroed."""
    band = res[W_BAND:W_BAND + 12].reshape(3, 4)
    floating = res[W_FLOAT:W_FLOAT + 3]
    band[:] = 0.0
    floating[:] = 0.0
    return band, floating


@njit
def segment_electric(T, nominal, locate, legs, st, dcx, prm, lut, level, res):
    """The circuit part of one segment of at most T [s]: returns the time integrated; results in
    res's RS_* slots."""
    ka, kb, kc, we = emf_at_mid(st, prm, lut, T)
    k, e = res[W_K:W_K + 3], res[W_E:W_E + 3]
    k[0], k[1], k[2] = ka, kb, kc
    e[0], e[1], e[2] = we * ka, we * kb, we * kc
    i = st[ST_I:ST_I + 3]
    dc_mode = int(prm[PR_DC])
    vp, vm = link_voltages(dcx, dc_mode, T)
    cond, u, rail = scratch_flags(res)
    vce, vd, ron = prm[PR_VCE], prm[PR_VD], prm[PR_RON]
    band, floating = scratch_bands(res)
    vn = resolve_legs(legs, i, e, vp, vm, vce, vd, ron, cond, u, rail, band, floating)
    if dc_mode == CURRENT_FED and cond[0] + cond[1] + cond[2] >= 2:
        vp, vm = corrected_link_voltages(T, nominal, st, dcx, prm, cond, u, vn, rail)
        vn = resolve_legs(legs, i, e, vp, vm, vce, vd, ron, cond, u, rail, band, floating)
    res[RS_VP] = vp
    if cond[0] + cond[1] + cond[2] >= 2:
        return conducting_segment(T, nominal, locate, legs, st, dcx, prm, level, cond, u, vn, rail,
                                  vp, vm, e, k, res)
    res[RS_TE] = res[RS_QP] = res[RS_QM] = 0.0
    res[RS_KIND], res[RS_Q] = EV_NONE, -1
    if i[0] or i[1] or i[2]:
        st[ST_I:ST_I + 3] = 0.0
    res[RS_DRAW] = 1.0 if T > 0.0 and dc_mode == CURRENT_FED else 0.0
    return T


@njit
def segment_mechanics(T, te, st, prm, load):
    """Shaft over the segment with the average torque te (:func:`.link_kernel.shaft_step`)."""
    w0 = st[ST_W]
    w1, w_avg, t_load, e_fric, e_load = shaft_step(load, prm[PR_J], prm[PR_B], w0, te, T)
    st[ST_W] = w1
    st[ST_TH] = st[ST_TH] + w_avg * T
    st[ST_ACC] = (w1 - w0) / T
    st[ST_TL] = t_load
    st[ST_FRIC] += e_fric
    st[ST_MECH] += e_load


@njit
def finish_segment(T, st, dcx, load, prm, res):
    """After segment_electric (and the front end): the soft link's charge balance and the shaft."""
    if res[RS_DRAW] != 0.0:
        link_draw(dcx, int(prm[PR_DC]), res[RS_QP], res[RS_QM], T)
    if T > 0.0:
        segment_mechanics(T, res[RS_TE], st, prm, load)


_log = FK.log_event
NO_FRONT_END = np.zeros(0)     # fp / fx of a plant without the front end


@njit
def integrate(dt, time, legs, all_off, st, dcx, load, prm, lut, level, res, ev, n_ev, fp, fx):
    """dt [s] of segments split at located events (past MAX_EVENTS_PER_STEP: unsplit, EV_LIMIT);
    a front end (fp, fx not empty) is advanced in each segment; a trip opens all legs and
    disables the level. Returns (n_ev, level)."""
    remaining = dt
    events = 0
    h = prm[PR_H]
    front_end = fp.shape[0] != 0
    while remaining > 1e-15:
        locate = events < MAX_EVENTS_PER_STEP
        if not locate and events == MAX_EVENTS_PER_STEP:
            n_ev = _log(ev, n_ev, time + st[ST_EL], EV_LIMIT, -1, 0.0)
        T = segment_electric(remaining, remaining == h, locate, legs, st, dcx, prm, lut, level, res)
        if front_end and res[RS_DRAW] != 0.0:
            q, n_ev = FK.advance(fp, fx, ev, n_ev, time + st[ST_EL], T, res[RS_VP])
            dcx[DC_SRC] = q / T
        finish_segment(T, st, dcx, load, prm, res)
        kind = int(res[RS_KIND])
        if kind != EV_NONE:
            q = int(res[RS_Q])
            n_ev = _log(ev, n_ev, time + st[ST_EL] + T, kind, q, st[ST_I + q])
            if kind == EV_TRIP:
                legs[:] = all_off
                level = 0.0
        remaining -= T
        st[ST_EL] += T
        events += 1
    return n_ev, level


@njit
def dead_time_split(dead, h, n):
    """The dead time covers k inner steps (k > 1 when longer than the step h): k equal pieces,
    then the rest k h - dead of the k-th step, then n - k full steps (n h = base tick)."""
    k = min(n, max(1, math.ceil(dead / h - 1e-9)))
    return k, dead / k, k * h - dead


@njit
def code_of(legs):
    """Three leg codes (-1..2) as one int: (l_a + 1) | (l_b + 1) << 2 | (l_c + 1) << 4."""
    return (legs[0] + 1) | (legs[1] + 1) << 2 | (legs[2] + 1) << 4


leg_code = interpreted(code_of)   # for Python callers with a tuple: no dispatch


@njit
def legs_into(code, legs):
    """The leg codes of code_of(legs) written into the int64 array legs (returned)."""
    for x in range(3):
        legs[x] = ((code >> (2 * x)) & 3) - 1
    return legs


@njit
def legs_of_code(code):
    """The leg codes of code_of(legs) as a new int64 array."""
    return legs_into(code, np.empty(3, np.int64))


@njit
def advance_tick(buf, lut, ev, time, level, legs_code, target_code, off_code, fp, fx):
    """One base tick (PlantCore.advance), the legs moving to the target through the dead time:
    (events logged in ev (when, kind, phase, current), leg code applied at the end)."""
    legs = legs_of_code(legs_code)
    n_ev = advance_legs(buf, lut, ev, time, level, legs, legs_of_code(target_code), legs_of_code(off_code),
                        fp, fx)
    return n_ev, code_of(legs)


@njit
def advance_legs(buf, lut, ev, time, level, legs, target, all_off, fp, fx):
    """advance_tick on leg arrays (legs updated in place): the number of events logged in ev."""
    return _advance(legs, target, all_off, time, buf[B_ST:B_DC], buf[B_DC:B_LOAD], buf[B_LOAD:B_PRM],
                    buf[B_PRM:B_SV], lut, level, buf[B_RES:B_SIZE], ev, fp, fx)


@njit
def _advance(legs, target, all_off, time, st, dcx, load, prm, lut, level, res, ev, fp, fx):
    n = int(prm[PR_N])
    h = prm[PR_H]
    st[ST_EL] = 0.0
    dead = prm[PR_DEAD]
    n_ev = 0
    changed = legs[0] != target[0] or legs[1] != target[1] or legs[2] != target[2]
    if dead > 0.0 and changed:
        k, piece, rest = dead_time_split(dead, h, n)
        for x in range(3):
            o, nw = legs[x], target[x]
            legs[x] = nw if nw == o or nw == OFF or nw == MIDPOINT else OFF
        for _ in range(k):
            n_ev, level = integrate(piece, time, legs, all_off, st, dcx, load, prm, lut, level, res, ev, n_ev,
                                    fp, fx)
        legs[:] = target   # as interpreted: the rest of the step takes the target legs
        n_ev, level = integrate(rest, time, legs, all_off, st, dcx, load, prm, lut, level, res, ev, n_ev, fp, fx)
        n -= k
    else:
        legs[:] = target
    for _ in range(n):
        n_ev, level = integrate(h, time, legs, all_off, st, dcx, load, prm, lut, level, res, ev, n_ev, fp, fx)
    return n_ev


@njit
def table_at(lut, prm, theta, out, at):
    """The three columns of a periodic table at theta [rad], interpolated, into out[at:]."""
    x = (theta * prm[PR_SCALE]) % prm[PR_POINTS]
    j = int(x)
    f = x - j
    for c in range(3):
        out[at + c] = lut[c, j] + f * (lut[c, j + 1] - lut[c, j])


@njit
def stored_energy(st, dcx, prm):
    """Motor magnetic (L - M)/2 sum i^2 + capacitors + kinetic J w^2 / 2 [J] (without a front end)."""
    i0, i1, i2 = st[ST_I], st[ST_I + 1], st[ST_I + 2]
    w = st[ST_W]
    return (0.5 * prm[PR_LM] * (i0 * i0 + i1 * i1 + i2 * i2) + link_stored_energy(dcx, int(prm[PR_DC]))
            + 0.5 * prm[PR_J] * w * w)


@njit
def state_values(buf, lut, lut_psi, legs_code):
    """PlantState's numeric fields at t_k into buf's SV_* part (terminal voltages with the legs)."""
    legs = legs_of_code(legs_code)
    st, dcx, prm, out = buf[B_ST:B_DC], buf[B_DC:B_LOAD], buf[B_PRM:B_SV], buf[B_SV:B_RES]
    p = prm[PR_P]
    theta_e = p * st[ST_TH]
    table_at(lut, prm, theta_e, out, SV_PSI)          # k_abc, scratch
    k0, k1, k2 = out[SV_PSI], out[SV_PSI + 1], out[SV_PSI + 2]
    we = p * st[ST_W]
    res = buf[B_RES:B_SIZE]
    e = res[W_E:W_E + 3]
    e[0], e[1], e[2] = we * k0, we * k1, we * k2
    i = st[ST_I:ST_I + 3]
    cond, u, rail = scratch_flags(res)
    band, floating = scratch_bands(res)
    vn = resolve_legs(legs, i, e, dcx[DC_VU] + dcx[DC_VL], dcx[DC_VL], prm[PR_VCE], prm[PR_VD],
                      prm[PR_RON], cond, u, rail, band, floating)
    table_at(lut_psi, prm, theta_e, out, SV_PSI)
    lm = prm[PR_LM]
    for x in range(3):
        out[SV_E + x] = e[x]
        out[SV_PSI + x] = lm * i[x] + out[SV_PSI + x]
        out[SV_TERM + x] = u[x] + e[x] if cond[x] else vn + e[x]
        out[SV_I + x] = i[x]
    out[SV_VN] = vn
    out[SV_TE] = p * (k0 * i[0] + k1 * i[1] + k2 * i[2])
    out[SV_ROTOR] = theta_e % TWO_PI
    out[SV_STORED] = stored_energy(st, dcx, prm)
    out[SV_VP] = dcx[DC_VU] + dcx[DC_VL]
    out[SV_VU], out[SV_VL], out[SV_ES] = dcx[DC_VU], dcx[DC_VL], dcx[DC_ES]
    out[SV_CU], out[SV_DEV], out[SV_FRIC], out[SV_MECH] = st[ST_CU], st[ST_DEV], st[ST_FRIC], st[ST_MECH]
    out[SV_TH], out[SV_W], out[SV_TL] = st[ST_TH], st[ST_W], st[ST_TL]
