"""Compiled front-end kernels of :class:`~.front_end.FrontEnd` (000 ch. III, docs/models.md
"Boost PFC front end") on float64 arrays: ``fp`` the circuit constants (``FP_*``), ``fx`` the
state, ledger and event counts (``FX_*``). :func:`advance` integrates [t, t + dt] with the link
voltage held; events are logged as rows (when, EV_FRONT_END + KIND_*, 0, value) in the plant's
format (switching events only with FP_LOG). Compiled and ``NUMBA_DISABLE_JIT=1`` runs agree
bit for bit.
"""
from __future__ import annotations

import math

from drive_common.compiled import njit

BLOCK, COND, OVERLAP = 0, 1, 2
BOOST_OVER_CURRENT = 2   # = dtc_msgs/PlantState PROTECTION_BOOST_OVER_CURRENT
BOOST_OVER_VOLTAGE = 4   # = dtc_msgs/PlantState PROTECTION_BOOST_OVER_VOLTAGE
MAX_PIECES_PER_ADVANCE = 100_000

# fp: circuit constants (FrontEnd.configure)
(FP_VPEAK, FP_OMEGA, FP_PHASE, FP_RS, FP_RL, FP_L, FP_LF, FP_RF, FP_RPLAIN, FP_CF, FP_C1, FP_VB, FP_RON,
 FP_VD, FP_FPWM, FP_TRIANGLE, FP_HMAX, FP_FILTER, FP_OC, FP_OV, FP_LATCHED, FP_LOG, FP_SIZE) = range(23)
# fx: state (time, i_f, v_c, i_L, bridge polarity, mode, gate, duty, enable, protection flags, PWM
# period of the last over-current trip, last switching event), ledger (FrontEndLedger), counts
(FX_TIME, FX_IF, FX_VC, FX_IL, FX_S, FX_MODE, FX_GATE, FX_DUTY, FX_ENABLE, FX_OC, FX_OV, FX_OC_PERIOD,
 FX_LAST_T, FX_LAST_KIND, FX_GRID, FX_DELIVERED, FX_LINE, FX_IND, FX_BRIDGE, FX_SWITCH, FX_DIODE,
 FX_NUM, FX_COUNTS) = range(23)
# event kinds (FrontEnd.event_counts keys, in this order); their counts at fx[FX_COUNTS + kind]
KIND_NAMES = ('zero', 'start', 'overlap', 'overlap_end', 'over_current', 'over_voltage')
KIND_ZERO, KIND_START, KIND_OVERLAP, KIND_OVERLAP_END, KIND_OVER_CURRENT, KIND_OVER_VOLTAGE = range(6)
FX_SIZE = FX_COUNTS + len(KIND_NAMES)
EV_FRONT_END = 16        # event-log kind of a front-end event: EV_FRONT_END + KIND_*
# front_end_values slots (PlantState's front-end fields at t_k)
(FV_GRID_V, FV_GRID_I, FV_RECT, FV_IL, FV_DUTY, FV_SWITCH, FV_E_GRID, FV_E_LOSS, FV_PROT, FV_STORED,
 FV_SIZE) = range(11)


@njit
def carrier(t: float, f_pwm: float, duty: float, triangle: bool):
    """PWM carrier locked to sim time: (switch on, next carrier edge after t, period index);
    triangle: on for [0, d T/2] and [T - d T/2, T], sawtooth: on for [0, d T)."""
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
    """Implicit-midpoint coefficients of a filter sub-step of h [s]: al = 2 L_f / h, g1, be = 2 C_2 / h,
    ga = 2 L / h, g3 (branch conductances), k_c, k_b (inverse node sums of COND / BLOCK)."""
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
    """One implicit-midpoint sub-step in a mode: mid values (a, b, c) of (i_f, v_c, i_L), end
    values (v_c1, i_L1) and whether an event lies inside it."""
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
    """Sub-steps of at most h_max over span [s] from t in one mode, stopping before an event:
    (t, i_f, v_c, i_L reached, last sub-step h, event inside it, link charge, ledger integrals
    of v_g i_f, i_f^2, i_L, i_L^2)."""
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
    """Implicit-midpoint mid values (i_f, v_c, i_L) and v_g(t + h/2) of a piece of h [s] in one mode."""
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
    """Event quantity after a piece of x [s] from t (> 0 before the event): i_L, s v_c, lim - i_L,
    i_L -+ i_f or the bridge drive."""
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
    """Smallest x in (0, h] with event_quantity(kind, x) <= 0 (bracketed Illinois iteration)."""
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


@njit
def log_event(ev, n_ev, when, kind, phase, value):
    """Row n_ev of an event log (when, kind, phase, value), dropped when the log is full; n_ev + 1."""
    if n_ev < ev.shape[0]:
        ev[n_ev, 0], ev[n_ev, 1], ev[n_ev, 2], ev[n_ev, 3] = when, kind, phase, value
    return n_ev + 1


@njit
def grid_voltage(fp, t):
    """v_g(t) = sqrt(2) V sin(w t + phi) [V] (module doc of :mod:`.front_end`)."""
    return fp[FP_VPEAK] * math.sin(fp[FP_OMEGA] * t + fp[FP_PHASE])


@njit
def switching_event(fp, fx, ev, n_ev, when, kind):
    """Count a switching event (KIND_ZERO .. KIND_OVERLAP_END); logged only with FP_LOG."""
    fx[FX_COUNTS + kind] += 1.0
    fx[FX_LAST_T], fx[FX_LAST_KIND] = when, kind
    if fp[FP_LOG] != 0.0:
        n_ev = log_event(ev, n_ev, when, EV_FRONT_END + kind, 0, 0.0)
    return n_ev


@njit
def trip_over_current(fp, fx, ev, n_ev):
    """Over-current (000 3.3): switch opened, flag raised, PWM period noted, trip logged with i_L."""
    fx[FX_OC] = 1.0
    fx[FX_GATE] = 0.0
    fx[FX_OC_PERIOD] = math.floor(fx[FX_TIME] * fp[FP_FPWM] + 1e-9)
    fx[FX_COUNTS + KIND_OVER_CURRENT] += 1.0
    return log_event(ev, n_ev, fx[FX_TIME], EV_FRONT_END + KIND_OVER_CURRENT, 0, fx[FX_IL])


@njit
def book_conduction(fp, fx, hc, c, gate, v_out):
    """Ledger of a piece with the inductor conducting at mid current c [A], hc = h c [C]:
    inductor resistance, bridge, switch or diode and link; returns the link charge."""
    fx[FX_IND] += fp[FP_RL] * c * hc
    fx[FX_BRIDGE] += fp[FP_VB] * hc
    if gate:
        fx[FX_SWITCH] += fp[FP_RON] * c * hc
        return 0.0
    fx[FX_DIODE] += fp[FP_VD] * hc
    fx[FX_DELIVERED] += v_out * hc
    return hc


@njit
def block_at_current_zero(fp, fx, ev, n_ev, when, i_end):
    """The located inductor-current zero at when: L i_end^2 / 2 of the piece's end current goes
    to the numerical ledger, i_L = 0 and the bridge blocks."""
    fx[FX_NUM] += 0.5 * fp[FP_L] * i_end * i_end
    fx[FX_IL] = 0.0
    fx[FX_MODE] = BLOCK
    return switching_event(fp, fx, ev, n_ev, when, KIND_ZERO)


@njit
def locate(fp, fx, kind, t, h, mode, s, R, u):
    """Time [s] after t of the first event of this kind inside (0, h] (:func:`locate_event`)."""
    return locate_event(kind, h, t, mode, s, R, u, fp[FP_OC], fp[FP_VPEAK], fp[FP_OMEGA], fp[FP_PHASE],
                        fp[FP_LF], fp[FP_RF], fp[FP_CF], fp[FP_L], fp[FP_VB], fx[FX_IF], fx[FX_VC], fx[FX_IL])


@njit
def mid(fp, fx, t, h, mode, s, R, u):
    """Midpoint-rule mid values (i_f, v_c, i_L) and v_g(t + h/2) of a piece (:func:`midpoint_values`)."""
    return midpoint_values(t, h, mode, s, R, u, fp[FP_VPEAK], fp[FP_OMEGA], fp[FP_PHASE], fp[FP_LF],
                           fp[FP_RF], fp[FP_CF], fp[FP_L], fp[FP_VB], fx[FX_IF], fx[FX_VC], fx[FX_IL])


# ---- no filter: one state i_L, bridge input = grid voltage
@njit
def plain_blocked(fp, fx, ev, n_ev, t, h, vg_mid, u_off):
    """With i_L = 0: (bridge blocked until a located start or the piece end (fx's time set), n_ev)."""
    V_b = fp[FP_VB]
    if abs(grid_voltage(fp, t)) - V_b - u_off > 0.0:
        return False, n_ev
    fx[FX_MODE] = BLOCK
    if abs(vg_mid) - V_b - u_off <= 0.0 and abs(grid_voltage(fp, t + h)) - V_b - u_off <= 0.0:
        fx[FX_TIME] = t + h
        return True, n_ev
    fx[FX_TIME] = t + locate(fp, fx, EV_PLAIN_START, t, h, BLOCK, 1, 0.0, u_off)
    return True, switching_event(fp, fx, ev, n_ev, fx[FX_TIME], KIND_START)


@njit
def plain_event(fp, t, h, gate, i0, i1, R, u_off):
    """(piece length, event) of a conducting piece: i_L zero at h = 2 L i0 / (R i0 - 2 D) or the
    limit at h = 2 L (i0 - lim) / (R (i0 + lim) - 2 D), D the mid-piece bridge drive (3 passes)."""
    L, V_b, lim = fp[FP_L], fp[FP_VB], fp[FP_OC]
    if i1 < 0.0:
        hz = h
        for _ in range(3):
            D = abs(grid_voltage(fp, t + 0.5 * hz)) - V_b - u_off
            den = R * i0 - 2.0 * D
            hz = min(h, 2.0 * L * i0 / den) if den > 0.0 else h
        return hz, EV_ZERO
    if gate and lim > 0.0 and i1 > lim and i0 < lim:
        hz = h
        for _ in range(3):
            D = abs(grid_voltage(fp, t + 0.5 * hz)) - V_b - u_off
            den = R * (i0 + lim) - 2.0 * D
            hz = min(h, 2.0 * L * (i0 - lim) / den) if den < 0.0 else h
        return hz, EV_OVER_CURRENT
    return h, 0


@njit
def piece_plain(fp, fx, ev, n_ev, t, h, gate, v_out):
    """One piece of at most h [s] from t without the filter (000 Fig. 3.1): midpoint rule on
    L di_L/dt = |v_g| - 2 V_f - R i_L - u, c = (g i0 + |v_g| - V_b - u) / (g + R), g = 2 L / h;
    (link charge, n_ev)."""
    vg = grid_voltage(fp, t + 0.5 * h)
    u_off = 0.0 if gate else v_out + fp[FP_VD]
    R = fp[FP_RPLAIN] + (fp[FP_RON] if gate else 0.0)
    i0 = fx[FX_IL]
    if i0 == 0.0:
        blocked, n_ev = plain_blocked(fp, fx, ev, n_ev, t, h, vg, u_off)
        if blocked:
            return 0.0, n_ev
    g = 2.0 * fp[FP_L] / h
    c = (g * i0 + abs(vg) - fp[FP_VB] - u_off) / (g + R)       # mid-piece current
    if i0 == 0.0 and c <= 0.0:        # forward bias too brief to build up current
        fx[FX_MODE] = BLOCK
        fx[FX_TIME] = t + h
        return 0.0, n_ev
    fx[FX_MODE] = COND
    fx[FX_S] = 1.0 if vg >= 0.0 else -1.0
    i1 = 2.0 * c - i0
    h, event = plain_event(fp, t, h, gate, i0, i1, R, u_off)
    if event != 0:
        vg = grid_voltage(fp, t + 0.5 * h)
        g = 2.0 * fp[FP_L] / h
        c = (g * i0 + abs(vg) - fp[FP_VB] - u_off) / (g + R)
        i1 = 2.0 * c - i0
    hc = h * c
    fx[FX_GRID] += abs(vg) * hc
    fx[FX_LINE] += fp[FP_RS] * c * hc
    q = book_conduction(fp, fx, hc, c, gate, v_out)
    fx[FX_TIME] = t + h
    if event == EV_ZERO:
        n_ev = block_at_current_zero(fp, fx, ev, n_ev, fx[FX_TIME], i1)
    else:
        fx[FX_IL] = i1
        if event == EV_OVER_CURRENT:
            n_ev = trip_over_current(fp, fx, ev, n_ev)
    return q, n_ev


# ---- EMI filter: states i_f, v_c, i_L
@njit
def start_mode(fp, fx, u):
    """The conduction mode consistent with the state at a piece start (a reverse-biased diagonal
    starts an overlap, v_c snapped to 0; a forward-biased bridge with i_L = 0 conduction)."""
    i_L, v_c, mode, s = fx[FX_IL], fx[FX_VC], int(fx[FX_MODE]), fx[FX_S]
    if i_L > 0.0:
        if mode == OVERLAP:
            if abs(fx[FX_IF]) > i_L:
                fx[FX_MODE], fx[FX_S] = COND, (1.0 if fx[FX_IF] > 0.0 else -1.0)
        elif mode != COND or s * v_c < 0.0:
            if s * v_c < 0.0:      # reverse biased diagonal: overlap (snap v_c)
                fx[FX_NUM] += 0.5 * fp[FP_CF] * v_c * v_c
                fx[FX_VC] = 0.0
                fx[FX_MODE] = OVERLAP
            else:
                fx[FX_MODE] = COND
    else:
        fx[FX_IL] = 0.0
        if abs(v_c) - fp[FP_VB] - u > 0.0:
            fx[FX_MODE], fx[FX_S] = COND, (1.0 if v_c > 0.0 else -1.0)
        else:
            fx[FX_MODE] = BLOCK


@njit
def book_substeps(fp, fx, e_grid, e_line, qc, sq, q, gate, v_out):
    """Ledger of sub-steps: e_line = int i_f^2, qc = int i_L, sq = int i_L^2, q = link charge."""
    fx[FX_GRID] += e_grid
    fx[FX_LINE] += fp[FP_RF] * e_line
    fx[FX_BRIDGE] += fp[FP_VB] * qc
    fx[FX_IND] += fp[FP_RL] * sq
    if gate:
        fx[FX_SWITCH] += fp[FP_RON] * sq
    else:
        fx[FX_DIODE] += fp[FP_VD] * q
        fx[FX_DELIVERED] += v_out * q


@njit
def piece_filter(fp, fx, ev, n_ev, t, span, gate, v_out):
    """Sub-steps over span [s] from t with a fixed gate (000 Fig. 3.1 with the EMI filter), up to
    an event located and taken there; (link charge, n_ev)."""
    u = 0.0 if gate else v_out + fp[FP_VD]
    R = fp[FP_RL] + (fp[FP_RON] if gate else 0.0)
    start_mode(fp, fx, u)
    mode, s = int(fx[FX_MODE]), int(fx[FX_S])
    (t, fx[FX_IF], fx[FX_VC], fx[FX_IL], h, event, q, e_grid, e_line, e_ind, e_sq) = filter_substeps(
        mode, s, gate, fp[FP_OC], fp[FP_VB], u, R, fp[FP_RF], 2.0 * fp[FP_LF], 2.0 * fp[FP_CF],
        2.0 * fp[FP_L], fp[FP_VPEAK], fp[FP_OMEGA], fp[FP_PHASE], fp[FP_HMAX], t, span, fx[FX_IF],
        fx[FX_VC], fx[FX_IL])
    fx[FX_TIME] = t
    book_substeps(fp, fx, e_grid, e_line, e_ind, e_sq, q, gate, v_out)
    if event:
        best, kind = first_filter_event(fp, fx, t, h, mode, s, R, u, gate)
        dq, n_ev = take_filter_event(fp, fx, ev, n_ev, t, best, kind, mode, s, R, u, gate, v_out)
        q += dq
    return q, n_ev


@njit
def earlier(fp, fx, kind, t, h, mode, s, R, u, best, event):
    """(best, event) updated with the located time of kind when not later (ties: the later check)."""
    th = locate(fp, fx, kind, t, h, mode, s, R, u)
    if th <= best:
        return th, kind
    return best, event


@njit
def first_filter_event(fp, fx, t, h, mode, s, R, u, gate):
    """(time to the first event in the sub-step of h from t, its EV_* kind; 0: none located)."""
    i_f0, v_c0, i_L0 = fx[FX_IF], fx[FX_VC], fx[FX_IL]
    lim = fp[FP_OC]
    a, b, c, vg = mid(fp, fx, t, h, mode, s, R, u)
    i_f1, v_c1, i_L1 = 2.0 * a - i_f0, 2.0 * b - v_c0, 2.0 * c - i_L0
    oc = gate and lim > 0.0 and i_L0 < lim
    best, event = h, 0
    if mode == COND:
        if i_L1 < 0.0:
            best, event = earlier(fp, fx, EV_ZERO, t, h, mode, s, R, u, best, event)
        if s * v_c1 < 0.0 < s * v_c0:
            best, event = earlier(fp, fx, EV_OVERLAP, t, h, mode, s, R, u, best, event)
        if oc and i_L1 > lim:
            best, event = earlier(fp, fx, EV_OVER_CURRENT, t, h, mode, s, R, u, best, event)
    elif mode == OVERLAP:
        if i_L1 - i_f1 <= 0.0:
            best, event = earlier(fp, fx, EV_OVERLAP_END_POS, t, h, mode, s, R, u, best, event)
        if i_L1 + i_f1 <= 0.0:
            best, event = earlier(fp, fx, EV_OVERLAP_END_NEG, t, h, mode, s, R, u, best, event)
        if oc and i_L1 > lim:
            best, event = earlier(fp, fx, EV_OVER_CURRENT, t, h, mode, s, R, u, best, event)
    else:
        thr = fp[FP_VB] + u
        if v_c1 - thr > 0.0:
            best, event = earlier(fp, fx, EV_START_POS, t, h, mode, s, R, u, best, event)
        if -v_c1 - thr > 0.0:
            best, event = earlier(fp, fx, EV_START_NEG, t, h, mode, s, R, u, best, event)
    return best, event


@njit
def take_filter_event(fp, fx, ev, n_ev, t, h, event, mode, s, R, u, gate, v_out):
    """Integrate the piece of h from t up to the located event and act on it; (link charge, n_ev)."""
    i_f0, v_c0, i_L0 = fx[FX_IF], fx[FX_VC], fx[FX_IL]
    a, b, c, vg = mid(fp, fx, t, h, mode, s, R, u)
    i_f1, v_c1, i_L1 = 2.0 * a - i_f0, 2.0 * b - v_c0, 2.0 * c - i_L0
    fx[FX_GRID] += h * vg * a
    fx[FX_LINE] += h * fp[FP_RF] * a * a
    q = book_conduction(fp, fx, h * c, c, gate, v_out) if mode != BLOCK else 0.0
    fx[FX_IF], fx[FX_VC], fx[FX_IL] = i_f1, v_c1, i_L1
    when = t + h
    fx[FX_TIME] = when
    if event == EV_ZERO:
        n_ev = block_at_current_zero(fp, fx, ev, n_ev, when, i_L1)
    elif event == EV_OVERLAP:
        fx[FX_NUM] += 0.5 * fp[FP_CF] * v_c1 * v_c1
        fx[FX_VC] = 0.0
        fx[FX_MODE] = OVERLAP
        n_ev = switching_event(fp, fx, ev, n_ev, when, KIND_OVERLAP)
    elif event == EV_OVERLAP_END_POS or event == EV_OVERLAP_END_NEG:
        fx[FX_MODE], fx[FX_S] = COND, (1.0 if event == EV_OVERLAP_END_POS else -1.0)
        n_ev = switching_event(fp, fx, ev, n_ev, when, KIND_OVERLAP_END)
    elif event == EV_START_POS or event == EV_START_NEG:
        fx[FX_MODE], fx[FX_S] = COND, (1.0 if event == EV_START_POS else -1.0)
        n_ev = switching_event(fp, fx, ev, n_ev, when, KIND_START)
    elif event == EV_OVER_CURRENT:
        n_ev = trip_over_current(fp, fx, ev, n_ev)
    return q, n_ev


# ---- one advance: pieces between PWM edges, zero crossings and located events
@njit
def piece_gate(fp, fx, ev, n_ev, tn, v_out):
    """At a piece start tn: cycle-by-cycle protection release, inrush over-current trip, and the
    gate (000 3.3); (gate, next carrier edge, n_ev)."""
    on, t_edge, k = carrier(tn, fp[FP_FPWM], fx[FX_DUTY], fp[FP_TRIANGLE] != 0.0)
    oc, ov = fx[FX_OC] != 0.0, fx[FX_OV] != 0.0
    if fp[FP_LATCHED] == 0.0 and (oc or ov):
        if oc and k > fx[FX_OC_PERIOD] and fx[FX_IL] <= fp[FP_OC]:
            fx[FX_OC] = 0.0
        if ov and v_out <= fp[FP_OV]:
            fx[FX_OV] = 0.0
    if fx[FX_IL] > fp[FP_OC] > 0.0 and fx[FX_OC] == 0.0:
        n_ev = trip_over_current(fp, fx, ev, n_ev)    # e.g. rectifier inrush with the switch already off
    gate = (on and fx[FX_ENABLE] != 0.0 and fx[FX_DUTY] > 0.0
            and not (fx[FX_OC] != 0.0 or fx[FX_OV] != 0.0))
    fx[FX_GATE] = 1.0 if gate else 0.0
    return gate, t_edge, n_ev


@njit
def advance(fp, fx, ev, n_ev, t, dt, v_out):
    """Integrate [t, t + dt] with the positive rail held at v_out [V] (mid-segment prediction):
    over-voltage check, pieces up to each PWM edge (and grid zero crossing without the filter);
    (charge [C] into the positive rail, n_ev)."""
    fx[FX_TIME] = t
    filt = fp[FP_FILTER] != 0.0
    vg0 = grid_voltage(fp, t) if filt else 0.0
    ov = fp[FP_OV]
    if ov > 0.0 and v_out > ov and fx[FX_OV] == 0.0:
        fx[FX_OV] = 1.0
        fx[FX_COUNTS + KIND_OVER_VOLTAGE] += 1.0
        n_ev = log_event(ev, n_ev, t, EV_FRONT_END + KIND_OVER_VOLTAGE, 0, v_out)
    q_total = 0.0
    t_end = t + dt
    eps = min(1e-9 / fp[FP_FPWM], 1e-6 * dt)   # edges this close to the end merge into it
    pieces = 0
    while t_end - fx[FX_TIME] > eps:
        pieces += 1
        if pieces > MAX_PIECES_PER_ADVANCE:
            raise RuntimeError('front end: too many pieces in one advance (chattering)')
        tn = fx[FX_TIME]
        gate, t_edge, n_ev = piece_gate(fp, fx, ev, n_ev, tn, v_out)
        t_stop = t_end if t_edge > t_end - eps else t_edge
        if filt:
            q, n_ev = piece_filter(fp, fx, ev, n_ev, tn, t_stop - tn, gate, v_out)
        else:
            # Split at the grid zero crossing (instantaneous commutation).
            ph = fp[FP_OMEGA] * tn + fp[FP_PHASE]
            t_zc = ((math.floor(ph / math.pi + 1e-12) + 1.0) * math.pi - fp[FP_PHASE]) / fp[FP_OMEGA]
            if t_zc < t_stop - eps:
                t_stop = t_zc
            q, n_ev = piece_plain(fp, fx, ev, n_ev, tn, t_stop - tn, gate, v_out)
        q_total += q
    fx[FX_TIME] = t_end
    if filt:
        vg1 = grid_voltage(fp, t_end)
        fx[FX_GRID] += 0.5 * fp[FP_C1] * (vg1 * vg1 - vg0 * vg0)   # C1: exact
    return q_total, n_ev


# ---- outputs
@njit
def stored_energy(fp, fx):
    """J: boost inductor, filter inductors, C2 and C1 (C1 at the grid voltage at fx's time)."""
    i_L = fx[FX_IL]
    e = 0.5 * fp[FP_L] * i_L * i_L
    if fp[FP_FILTER] != 0.0:
        vg = grid_voltage(fp, fx[FX_TIME])
        i_f, v_c = fx[FX_IF], fx[FX_VC]
        e += 0.5 * (fp[FP_LF] * i_f * i_f + fp[FP_CF] * v_c * v_c + fp[FP_C1] * vg * vg)
    return e


@njit
def losses(fx):
    """J: line and inductor resistances, bridge, switch, diode and the numerical snaps."""
    return (fx[FX_LINE] + fx[FX_IND] + fx[FX_BRIDGE] + fx[FX_SWITCH] + fx[FX_DIODE] + fx[FX_NUM])


@njit
def grid_current(fp, fx):
    """A, line current at fx's time (filter: i_f + C1 dv_g/dt; else the bridge input current)."""
    if fp[FP_FILTER] != 0.0:
        t = fx[FX_TIME]
        return fx[FX_IF] + fp[FP_C1] * (fp[FP_VPEAK] * fp[FP_OMEGA] * math.cos(fp[FP_OMEGA] * t + fp[FP_PHASE]))
    if fx[FX_MODE] == COND:
        return fx[FX_S] * fx[FX_IL]
    return 0.0


@njit
def rectified_voltage(fp, fx):
    """V, |bridge input|: |v_c| (filter) or |v_g| at fx's time, as the PFC senses it."""
    return abs(fx[FX_VC] if fp[FP_FILTER] != 0.0 else grid_voltage(fp, fx[FX_TIME]))


@njit
def front_end_values(fp, fx, plant_time, out):
    """PlantState's front-end fields at the plant's time into out (FV_*; only the front end's bits)."""
    on = fx[FX_ENABLE] != 0.0 and not (fx[FX_OC] != 0.0 or fx[FX_OV] != 0.0)
    out[FV_GRID_V] = grid_voltage(fp, plant_time)
    out[FV_GRID_I] = grid_current(fp, fx)
    out[FV_RECT] = rectified_voltage(fp, fx)
    out[FV_IL] = fx[FX_IL]
    out[FV_DUTY] = fx[FX_DUTY] if on else 0.0
    out[FV_SWITCH] = 1.0 if on else 0.0
    out[FV_E_GRID] = fx[FX_GRID]
    out[FV_E_LOSS] = losses(fx)
    out[FV_PROT] = ((BOOST_OVER_CURRENT if fx[FX_OC] != 0.0 else 0)
                    | (BOOST_OVER_VOLTAGE if fx[FX_OV] != 0.0 else 0))
    out[FV_STORED] = stored_energy(fp, fx)
