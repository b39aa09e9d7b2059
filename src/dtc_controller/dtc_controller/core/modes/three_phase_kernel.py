"""Compiled per-sample pipeline of the three-phase DTC modes (000 ch. I and V; 001).

:func:`three_phase_step` is :class:`three_phase_pmsm.ThreePhaseBase`'s sample on float64 arrays:
applied voltage of sample k-1 (plus the :mod:`voltage_drop_compensation` correction), stator flux
by a voltage model (:mod:`stator_flux_estimators`) or the current model (001 eqs. 8-9), rotor
angle and speed, torque (001 eq. 10, or 000 eq. 5.32 for DTIFC), torque reference, hysteresis,
sector and table lookup; compiled and interpreted runs agree bit for bit.
"""
from __future__ import annotations

import math

import numpy as np

from drive_common.compiled import njit
from drive_common.signals import TWO_PI

from ..hysteresis import two_level
from ..speed_loop import speed_pi_update
from ..stator_flux_estimators import compensate_low_pass, integrator_step, rotor_angle
from ..switching_tables import sector_of_angle
from ..three_phase_tables import four_sector_of_angle
from ..voltage_drop_compensation import correction
from .two_phase_kernel import coefficient_table, interp, leg_codes, selection_table

# Table rows (each periodic: points + 1 values): rotor flux alpha/beta, k_d, k_q.
R_PSI_ALPHA, R_PSI_BETA, R_K_D, R_K_Q = range(4)
# Parameter vector (float64; flags 0/1, codes as floats).
(P_L, P_POLES, P_R, P_TS, P_PSI_M, P_ROTOR_TABLE, P_SCALE, P_POINTS, P_CURRENT_MODEL, P_INTEGRATOR,
 P_CUTOFF, P_LEAK, P_LIMIT, P_SENSORLESS, P_INITIAL_ANGLE, P_INIT_ROTOR, P_SPEED_GAIN, P_FOUR_SECTORS,
 P_DTIFC, P_FLUX_REF_TABLE, P_LPF_COMP, P_SCHEME, P_V_CE, P_V_D, P_V_F, P_R_ON, P_MIDPOINT, P_FLUX_REF,
 P_ROTATION, P_TORQUE_REF, P_SPEED_LOOP, P_SPEED_REF, P_TORQUE_BAND, P_FLUX_BAND, P_ID_REF, P_KP, P_KI,
 P_EVERY_N, P_TORQUE_LIMIT, P_SIZE) = range(40)
# State (float64).
(S_STARTED, S_PSI_ALPHA, S_PSI_BETA, S_I_ALPHA, S_I_BETA, S_PREV_VECTOR, S_PREV_VDC, S_PREV_VMID,
 S_PREV_IA, S_PREV_IB, S_PREV_IC, S_PREV_THETA, S_OMEGA_E, S_TAU, S_PHI, S_PI_INTEGRAL, S_PI_OUTPUT,
 S_PI_COUNT, S_SIZE) = range(19)
# Outputs of one sample.
(O_VECTOR, O_TORQUE_REF, O_SPEED_REF, O_TORQUE, O_PSI_ALPHA, O_PSI_BETA, O_PSI_MAG, O_FLUX_REF,
 O_ID_REF, O_I_D, O_I_Q, O_THETA, O_OMEGA_E, O_SECTOR, O_TAU, O_PHI, O_D_STATE, O_SIZE) = range(18)


def mode_arrays(tables: dict, dq) -> tuple:
    """(vectors, table rows, coefficients, leg codes, upper-switch states, {rotation: selection})."""
    unique = {v.switch_on: v for table in tables.values() for v in table.values()}
    vectors = sorted(unique.values(), key=lambda v: (v.index, v.switch_on))
    upper = np.array([[int(v.switch_on[2 * x]) for x in range(3)] for v in vectors], dtype=np.int64)
    tab = (np.array([dq.table._psia, dq.table._psib, dq._kd, dq._kq], dtype=np.float64) if dq is not None
           else np.zeros((4, 2)))
    select = {r: selection_table(t, vectors) for r, t in tables.items()}
    return tuple(vectors), tab, coefficient_table(), leg_codes(vectors), upper, select


@njit
def _rotor_flux(prm, tab, theta: float):
    """Rotor flux (alpha, beta) [Wb] at theta: the back-EMF table's integral or psi_m (cos, sin)."""
    if prm[P_ROTOR_TABLE] != 0.0:
        scale, points = prm[P_SCALE], int(prm[P_POINTS])
        return (interp(tab, R_PSI_ALPHA, scale, points, theta), interp(tab, R_PSI_BETA, scale, points, theta))
    return prm[P_PSI_M] * math.cos(theta), prm[P_PSI_M] * math.sin(theta)


@njit
def _applied_voltage(prm, st, coef, legs, upper, i_a, i_b, i_c):
    """(v_alpha, v_beta) [V] of sample k-1: ideal vector plus the drop correction (001 eqs. 24-38)."""
    vec = int(st[S_PREV_VECTOR])
    lg = legs[vec]
    c = coef[16 * lg[0] + 4 * lg[1] + lg[2]]
    v_dc, v_mid = st[S_PREV_VDC], st[S_PREV_VMID]
    v_al = c[0] * v_dc + c[1] * v_mid
    v_be = c[2] * v_dc + c[3] * v_mid
    if prm[P_SCHEME] != 0.0:
        d_al, d_be = correction(int(prm[P_SCHEME]), int(prm[P_MIDPOINT]), upper[vec, 0] != 0, upper[vec, 1] != 0,
                                upper[vec, 2] != 0, 0.5 * (st[S_PREV_IA] + i_a), 0.5 * (st[S_PREV_IB] + i_b),
                                0.5 * (st[S_PREV_IC] + i_c), prm[P_V_CE], prm[P_V_D], prm[P_V_F], prm[P_R_ON])
        v_al += d_al
        v_be += d_be
    return v_al, v_be


@njit
def _flux(prm, st, tab, coef, legs, upper, i_a, i_b, i_c, i_al, i_be, theta_enc, speed_m) -> None:
    """Stator flux at sample k into st: the current model (001 eqs. 8-9) or a voltage model."""
    if prm[P_CURRENT_MODEL] != 0.0:
        ra, rb = _rotor_flux(prm, tab, theta_enc)
        st[S_PSI_ALPHA] = prm[P_L] * i_al + ra
        st[S_PSI_BETA] = prm[P_L] * i_be + rb
        return
    kind = int(prm[P_INTEGRATOR])
    if st[S_STARTED] == 0.0:
        sensorless = prm[P_SENSORLESS] != 0.0
        theta0 = prm[P_INITIAL_ANGLE] if sensorless else theta_enc
        p_al = p_be = 0.0
        if prm[P_INIT_ROTOR] != 0.0:
            r_al, r_be = _rotor_flux(prm, tab, theta0)
            p_al, p_be = r_al + prm[P_L] * i_al, r_be + prm[P_L] * i_be
            w0 = 0.0 if sensorless else int(prm[P_POLES]) * speed_m
            cutoff = prm[P_CUTOFF]
            if kind == 1 and prm[P_LPF_COMP] != 0.0 and abs(w0) > 0.5 * cutoff:
                r = cutoff / w0
                p_al, p_be = (p_al - r * p_be) / (1.0 + r * r), (p_be + r * p_al) / (1.0 + r * r)
        st[S_PSI_ALPHA], st[S_PSI_BETA] = p_al, p_be
        st[S_PREV_THETA] = theta0
    else:
        v_al, v_be = _applied_voltage(prm, st, coef, legs, upper, i_a, i_b, i_c)
        st[S_PSI_ALPHA], st[S_PSI_BETA] = integrator_step(
            kind, prm[P_R], prm[P_TS], prm[P_LEAK], prm[P_LIMIT], st[S_PSI_ALPHA], st[S_PSI_BETA],
            st[S_I_ALPHA], st[S_I_BETA], v_al, v_be, i_al, i_be)
    st[S_I_ALPHA] = i_al
    st[S_I_BETA] = i_be


@njit
def _angle_and_speed(prm, st, psi_al, psi_be, i_al, i_be, theta_enc, speed_m):
    """(rotor angle [rad], electrical speed [rad/s]): encoder, or eq. (5.38) + filtered derivative."""
    if prm[P_SENSORLESS] == 0.0:
        st[S_OMEGA_E] = int(prm[P_POLES]) * speed_m
        return theta_enc, st[S_OMEGA_E]
    theta = rotor_angle(psi_al, psi_be, i_al, i_be, prm[P_L])
    if st[S_STARTED] != 0.0:
        d = theta - st[S_PREV_THETA]
        if d > math.pi:
            d -= TWO_PI
        elif d < -math.pi:
            d += TWO_PI
        st[S_OMEGA_E] += prm[P_SPEED_GAIN] * (d / prm[P_TS] - st[S_OMEGA_E])
    st[S_PREV_THETA] = theta
    return theta, st[S_OMEGA_E]


@njit
def three_phase_step(prm, st, tab, coef, legs, upper, select, i_a, i_b, i_c, i_al, i_be, theta_enc,
                     v_dc, v_mid, speed_m, out) -> None:
    """One controller sample (module doc) into out[O_*]."""
    _flux(prm, st, tab, coef, legs, upper, i_a, i_b, i_c, i_al, i_be, theta_enc, speed_m)
    psi_al, psi_be = st[S_PSI_ALPHA], st[S_PSI_BETA]
    theta, w_e = _angle_and_speed(prm, st, psi_al, psi_be, i_al, i_be, theta_enc, speed_m)
    p = int(prm[P_POLES])
    sensorless = prm[P_SENSORLESS] != 0.0
    c, sn = math.cos(theta), math.sin(theta)
    i_d = i_al * c + i_be * sn
    i_q = -i_al * sn + i_be * c
    dtifc = prm[P_DTIFC] != 0.0
    if dtifc:
        scale, points = prm[P_SCALE], int(prm[P_POINTS])
        k_d = interp(tab, R_K_D, scale, points, theta)
        k_q = interp(tab, R_K_Q, scale, points, theta)
        torque = 1.5 * p * (k_d * i_d + k_q * i_q)          # 000 eq. (5.32)
    else:
        if prm[P_LPF_COMP] != 0.0 and int(prm[P_INTEGRATOR]) == 1 and prm[P_CURRENT_MODEL] == 0.0:
            psi_al, psi_be = compensate_low_pass(psi_al, psi_be, w_e, prm[P_CUTOFF], 0.5 * prm[P_CUTOFF])
        torque = 1.5 * p * (psi_al * i_be - psi_be * i_al)  # 001 eq. (10)
    psi_mag = math.sqrt(psi_al * psi_al + psi_be * psi_be)
    speed_reg = w_e / p if sensorless else speed_m
    t_ref, speed_ref = prm[P_TORQUE_REF], math.nan
    if prm[P_SPEED_LOOP] != 0.0:
        integral, output, count = speed_pi_update(
            prm[P_KP], prm[P_KI], int(prm[P_EVERY_N]), prm[P_TS], prm[P_TORQUE_LIMIT],
            st[S_PI_INTEGRAL], st[S_PI_OUTPUT], int(st[S_PI_COUNT]), prm[P_SPEED_REF], speed_reg)
        st[S_PI_INTEGRAL], st[S_PI_OUTPUT], st[S_PI_COUNT] = integral, output, count
        t_ref, speed_ref = output, prm[P_SPEED_REF]
    rot = int(prm[P_ROTATION])
    tau = two_level(int(st[S_TAU]), prm[P_TORQUE_BAND], rot * (t_ref - torque))
    flux_ref = math.nan
    if dtifc:
        phi = two_level(int(st[S_PHI]), prm[P_FLUX_BAND], prm[P_ID_REF] - i_d)
    else:
        if prm[P_FLUX_REF_TABLE] != 0.0:
            r_al, r_be = _rotor_flux(prm, tab, theta)
            flux_ref = math.sqrt(r_al * r_al + r_be * r_be)
        else:
            flux_ref = prm[P_FLUX_REF]
        phi = two_level(int(st[S_PHI]), prm[P_FLUX_BAND], flux_ref - psi_mag)
    st[S_TAU], st[S_PHI] = tau, phi
    ang = math.atan2(psi_be, psi_al)
    sector = four_sector_of_angle(ang) if prm[P_FOUR_SECTORS] != 0.0 else sector_of_angle(ang)
    vector = select[sector - 1, 1 - phi, (1 - tau) // 2]
    st[S_STARTED] = 1.0
    st[S_PREV_VECTOR] = vector
    st[S_PREV_VDC], st[S_PREV_VMID] = v_dc, v_mid
    st[S_PREV_IA], st[S_PREV_IB], st[S_PREV_IC] = i_a, i_b, i_c
    out[O_VECTOR], out[O_TORQUE_REF], out[O_SPEED_REF], out[O_TORQUE] = vector, t_ref, speed_ref, torque
    out[O_PSI_ALPHA], out[O_PSI_BETA], out[O_PSI_MAG], out[O_FLUX_REF] = psi_al, psi_be, psi_mag, flux_ref
    out[O_ID_REF] = prm[P_ID_REF] if dtifc else math.nan
    out[O_I_D], out[O_I_Q], out[O_THETA] = i_d, i_q, theta
    out[O_OMEGA_E] = w_e if sensorless else math.nan
    out[O_SECTOR], out[O_TAU], out[O_PHI] = sector, tau, phi
    out[O_D_STATE] = phi if dtifc else 0
