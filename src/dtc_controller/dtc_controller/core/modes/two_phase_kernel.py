"""Compiled per-sample pipeline of the two-phase BLDC DTC modes (000 ch. II and IV).

:func:`two_phase_step` is :class:`two_phase_base.TwoPhaseModeBase`'s sample on float64 arrays:
applied voltage of sample k-1 (:func:`applied_voltage`), voltage-model flux (eqs. 1.22-1.23),
torque (eq. 2.16/4.1), torque reference, sector, hysteresis (eqs. 1.19-1.20), table lookup and,
for the four-switch inverter, the split-phase torques of sectors II/V (eq. 4.4).
"""
from __future__ import annotations

import math
from itertools import product

import numpy as np

from drive_common.compiled import njit

from ..hysteresis import two_level
from ..speed_loop import speed_pi_update
from ..stator_flux_estimators import trapezoid_flux_step
from ..switching_tables import sector_of_angle
from ..vectors import HIGH, LOW, MIDPOINT, OPEN, voltage_coefficients

LEG_CODES = {HIGH: 0, LOW: 1, OPEN: 2, MIDPOINT: 3}
L_HIGH, L_LOW, L_OPEN = 0, 1, 2

# Back-EMF table rows of the kernel's table array (each periodic: points + 1 values).
K_A, K_B, K_C, K_ALPHA, K_BETA, PSI_ALPHA, PSI_BETA, PSI_MAG = range(8)
# Parameter vector (float64; flags 0/1).
(P_R, P_TS, P_L, P_POLES, P_TORQUE_C, P_SCALE, P_POINTS, P_DIODE, P_THRESHOLD, P_OPEN_EMF,
 P_FLUX_SECTOR, P_INIT_TABLE, P_FLUX_CONTROL, P_FLUX_REF_TABLE, P_FLUX_REF, P_ROTATION,
 P_TORQUE_REF, P_SPEED_LOOP, P_SPEED_REF, P_TORQUE_BAND, P_FLUX_BAND, P_SPLIT_BAND, P_KP, P_KI,
 P_EVERY_N, P_TORQUE_LIMIT, P_SIZE) = range(27)
# State (float64): started, flux estimator, previous sample, comparators, speed PI.
(S_STARTED, S_PSI_ALPHA, S_PSI_BETA, S_PRIMED, S_I_ALPHA, S_I_BETA, S_PREV_VECTOR, S_PREV_VDC,
 S_PREV_VMID, S_PREV_IA, S_PREV_IB, S_PREV_IC, S_TAU, S_PHI, S_TAU_A, S_TAU_B, S_PI_INTEGRAL,
 S_PI_OUTPUT, S_PI_COUNT, S_SIZE) = range(20)
# Outputs of one sample.
(O_VECTOR, O_TORQUE_REF, O_SPEED_REF, O_TORQUE, O_TORQUE_A, O_TORQUE_B, O_PSI_ALPHA, O_PSI_BETA,
 O_PSI_MAG, O_FLUX_REF, O_I_D, O_I_Q, O_SECTOR, O_TAU, O_PHI, O_SIZE) = range(16)


def table_array(table) -> np.ndarray:
    """The back-EMF table's periodic columns as rows K_A..PSI_MAG of one float64 array."""
    return np.array([table._ka, table._kb, table._kc, table._kal, table._kbe,
                     table._psia, table._psib, table._psim], dtype=np.float64)


def leg_codes(vectors) -> np.ndarray:
    """(len(vectors), 3) int64 leg codes (LEG_CODES) of each vector."""
    return np.array([[LEG_CODES[leg] for leg in v.legs] for v in vectors], dtype=np.int64)


def coefficient_table() -> np.ndarray:
    """(64, 10) linear voltage model of every leg pattern (index 16 a + 4 b + c):
    a_dc, a_mid, b_dc, b_mid, then (ka, kb) of the open-phase EMF terms of phases a, b, c."""
    out = np.zeros((64, 10))
    for index, legs in enumerate(product(LEG_CODES, repeat=3)):   # LEG_CODES in code order 0..3
        a_dc, a_mid, b_dc, b_mid, terms = voltage_coefficients(legs)
        out[index, :4] = a_dc, a_mid, b_dc, b_mid
        for x, ka, kb in terms:
            out[index, 4 + 2 * x:6 + 2 * x] = ka, kb
    return out


def selection_table(table: dict, vectors) -> np.ndarray:
    """{(sector, b, c): vector} as an int64 array [sector - 1, 1 - b, (1 - c) // 2] of positions in vectors."""
    position = {v.switch_on: n for n, v in enumerate(vectors)}
    out = np.full((6, 3, 2), -1, dtype=np.int64)
    for (sector, b, c), v in table.items():
        out[sector - 1, 1 - b, (1 - c) // 2] = position[v.switch_on]
    return out


@njit
def interp(tab, row: int, scale: float, points: int, theta: float) -> float:
    """Linear, wrapped lookup of a table row at theta [rad] (as BackEmfTable lookups)."""
    x = theta * scale
    i = math.floor(x)
    f = x - i
    i %= points
    return tab[row, i] + f * (tab[row, i + 1] - tab[row, i])


@njit
def applied_voltage(coef, legs, diode: bool, threshold: float, v_dc: float, v_mid: float,
                    i_a: float, i_b: float, i_c: float, use_emf: bool, e_a: float, e_b: float,
                    e_c: float):
    """(v_alpha, v_beta) [V] of a leg pattern: ideal legs, or (diode) off legs still carrying
    current clamped by a free-wheeling diode; plus the open phases' back-EMF terms (use_emf)."""
    la, lb, lc = legs[0], legs[1], legs[2]
    if diode and (la == L_OPEN or lb == L_OPEN or lc == L_OPEN):
        la = la if la != L_OPEN else L_LOW if i_a > threshold else L_HIGH if i_a < -threshold else L_OPEN
        lb = lb if lb != L_OPEN else L_LOW if i_b > threshold else L_HIGH if i_b < -threshold else L_OPEN
        lc = lc if lc != L_OPEN else L_LOW if i_c > threshold else L_HIGH if i_c < -threshold else L_OPEN
    c = coef[16 * la + 4 * lb + lc]
    v_al = c[0] * v_dc + c[1] * v_mid
    v_be = c[2] * v_dc + c[3] * v_mid
    if use_emf:
        if la == L_OPEN:
            v_al += c[4] * e_a
            v_be += c[5] * e_a
        if lb == L_OPEN:
            v_al += c[6] * e_b
            v_be += c[7] * e_b
        if lc == L_OPEN:
            v_al += c[8] * e_c
            v_be += c[9] * e_c
    return v_al, v_be


@njit
def _flux(prm, st, tab, coef, legs, i_a, i_b, i_c, i_al, i_be, theta, speed_m) -> None:
    """Eqs. (1.22)-(1.23): advance the stator flux with v(k-1) and i(k) (first sample: only store i)."""
    scale, points = prm[P_SCALE], int(prm[P_POINTS])
    v_al = v_be = 0.0
    if st[S_STARTED] == 0.0:
        if prm[P_INIT_TABLE] != 0.0:
            st[S_PSI_ALPHA] = interp(tab, PSI_ALPHA, scale, points, theta) + prm[P_L] * i_al
            st[S_PSI_BETA] = interp(tab, PSI_BETA, scale, points, theta) + prm[P_L] * i_be
            st[S_PRIMED] = 0.0
    else:
        e_a = e_b = e_c = 0.0
        use_emf = prm[P_OPEN_EMF] != 0.0
        if use_emf:
            w = int(prm[P_POLES]) * speed_m
            e_a = w * interp(tab, K_A, scale, points, theta)
            e_b = w * interp(tab, K_B, scale, points, theta)
            e_c = w * interp(tab, K_C, scale, points, theta)
        v_al, v_be = applied_voltage(coef, legs[int(st[S_PREV_VECTOR])], prm[P_DIODE] != 0.0,
                                     prm[P_THRESHOLD], st[S_PREV_VDC], st[S_PREV_VMID], st[S_PREV_IA],
                                     st[S_PREV_IB], st[S_PREV_IC], use_emf, e_a, e_b, e_c)
    if st[S_PRIMED] != 0.0:
        st[S_PSI_ALPHA], st[S_PSI_BETA] = trapezoid_flux_step(
            st[S_PSI_ALPHA], st[S_PSI_BETA], v_al, v_be, prm[P_R], prm[P_TS], st[S_I_ALPHA],
            st[S_I_BETA], i_al, i_be)
    st[S_PRIMED] = 1.0
    st[S_I_ALPHA] = i_al
    st[S_I_BETA] = i_be


@njit
def _torque_reference(prm, st, speed_m: float):
    """(T* [N m], speed reference [rad/s] or NaN): the parameter or the speed PI (Figs. 2.3 / 4.7)."""
    if prm[P_SPEED_LOOP] == 0.0:
        return prm[P_TORQUE_REF], math.nan
    integral, output, count = speed_pi_update(
        prm[P_KP], prm[P_KI], int(prm[P_EVERY_N]), prm[P_TS], prm[P_TORQUE_LIMIT],
        st[S_PI_INTEGRAL], st[S_PI_OUTPUT], int(st[S_PI_COUNT]), prm[P_SPEED_REF], speed_m)
    st[S_PI_INTEGRAL] = integral
    st[S_PI_OUTPUT] = output
    st[S_PI_COUNT] = count
    return output, prm[P_SPEED_REF]


@njit
def _split_phase(prm, st, tab, theta, i_a, i_b, t_ref):
    """Eq. (4.4) phase torques with the zero sequence (k_a - k_b)/2 and their comparators (Table V)."""
    scale, points = prm[P_SCALE], int(prm[P_POINTS])
    p = int(prm[P_POLES])
    k_half = 0.5 * (interp(tab, K_A, scale, points, theta) - interp(tab, K_B, scale, points, theta))
    t_a = p * k_half * i_a
    t_b = p * -k_half * i_b
    half = 0.5 * t_ref
    rot = int(prm[P_ROTATION])
    st[S_TAU_A] = two_level(int(st[S_TAU_A]), prm[P_SPLIT_BAND], rot * (half - t_a))
    st[S_TAU_B] = two_level(int(st[S_TAU_B]), prm[P_SPLIT_BAND], rot * (half - t_b))
    return t_a, t_b


@njit
def two_phase_step(prm, st, tab, coef, legs, select, split_select, i_a, i_b, i_c, i_al, i_be,
                   theta, v_dc, v_mid, speed_m, out) -> None:
    """One controller sample (module doc) into out[O_*]; split_select[s, 0, 0] < 0: no split sector s."""
    scale, points = prm[P_SCALE], int(prm[P_POINTS])
    _flux(prm, st, tab, coef, legs, i_a, i_b, i_c, i_al, i_be, theta, speed_m)
    psi_al, psi_be = st[S_PSI_ALPHA], st[S_PSI_BETA]
    psi_mag = math.sqrt(psi_al * psi_al + psi_be * psi_be)
    torque = prm[P_TORQUE_C] * (interp(tab, K_ALPHA, scale, points, theta) * i_al
                                + interp(tab, K_BETA, scale, points, theta) * i_be)   # eq. (2.16)
    t_ref, speed_ref = _torque_reference(prm, st, speed_m)
    ang = math.atan2(psi_be, psi_al) if prm[P_FLUX_SECTOR] != 0.0 else theta
    sector = sector_of_angle(ang)
    rot = int(prm[P_ROTATION])
    tau = two_level(int(st[S_TAU]), prm[P_TORQUE_BAND], rot * (t_ref - torque))
    st[S_TAU] = tau
    flux_ref = math.nan
    phi = 0
    if prm[P_FLUX_CONTROL] != 0.0:
        flux_ref = (interp(tab, PSI_MAG, scale, points, theta) if prm[P_FLUX_REF_TABLE] != 0.0
                    else prm[P_FLUX_REF])
        phi = two_level(int(st[S_PHI]), prm[P_FLUX_BAND], flux_ref - psi_mag)
        st[S_PHI] = phi
    t_a = t_b = math.nan
    if split_select[sector - 1, 0, 0] >= 0:
        t_a, t_b = _split_phase(prm, st, tab, theta, i_a, i_b, t_ref)
        vector = split_select[sector - 1, 1 - int(st[S_TAU_A]), (1 - int(st[S_TAU_B])) // 2]
    else:
        vector = select[sector - 1, 1 - phi, (1 - tau) // 2]
    st[S_STARTED] = 1.0
    st[S_PREV_VECTOR] = vector
    st[S_PREV_VDC], st[S_PREV_VMID] = v_dc, v_mid
    st[S_PREV_IA], st[S_PREV_IB], st[S_PREV_IC] = i_a, i_b, i_c
    c, sn = math.cos(theta), math.sin(theta)
    out[O_VECTOR], out[O_TORQUE_REF], out[O_SPEED_REF], out[O_TORQUE] = vector, t_ref, speed_ref, torque
    out[O_TORQUE_A], out[O_TORQUE_B], out[O_PSI_ALPHA], out[O_PSI_BETA] = t_a, t_b, psi_al, psi_be
    out[O_PSI_MAG], out[O_FLUX_REF], out[O_SECTOR], out[O_TAU], out[O_PHI] = psi_mag, flux_ref, sector, tau, phi
    out[O_I_D] = i_al * c + i_be * sn
    out[O_I_Q] = -i_al * sn + i_be * c
