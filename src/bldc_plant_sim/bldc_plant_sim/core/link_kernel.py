"""Compiled DC-link and shaft updates of one integration segment: the equations of :mod:`.dc_link`
(``DC_*`` slots of DcLink.x) and :mod:`.load` (``LD_*`` slots of LoadMachine.x)."""
from __future__ import annotations

from drive_common.compiled import libm_pow, njit

# DcLink.x slots
DC_VU, DC_VL, DC_ES, DC_IP, DC_IM, DC_IS, DC_SRC, DC_V, DC_CU, DC_CL = range(10)
DC_SIZE = 10
IDEAL, SPLIT, CURRENT_FED = 0, 1, 2
TORQUE, VISCOUS, DYNAMOMETER = 0, 1, 2
# LoadMachine.x slots
LD_MODE, LD_TORQUE, LD_VISCOUS, LD_SPEED = range(4)
LD_SIZE = 4


@njit
def link_voltages(x, mode, dt):
    """(V_P, V_M) [V] predicted at the middle of the next segment of length dt (dc_link docstring)."""
    if mode == IDEAL:
        return x[DC_VU] + x[DC_VL], x[DC_VL]
    if mode == SPLIT:
        return x[DC_V], x[DC_VL] - 0.5 * dt * x[DC_IM] / (x[DC_CU] + x[DC_CL])
    d_up = 0.5 * dt * (x[DC_IS] - x[DC_IP]) / x[DC_CU]
    d_lo = 0.5 * dt * (x[DC_IS] - x[DC_IP] - x[DC_IM]) / x[DC_CL]
    return x[DC_VU] + d_up + x[DC_VL] + d_lo, x[DC_VL] + d_lo


@njit
def link_draw(x, mode, q_p, q_m, dt):
    """The inverter drew charge q_p [C] from P and q_m from M over dt [s] (dc_link docstring)."""
    x[DC_IP], x[DC_IM] = q_p / dt, q_m / dt
    if mode == IDEAL:
        x[DC_ES] += (x[DC_VU] + x[DC_VL]) * q_p + x[DC_VL] * q_m
    elif mode == SPLIT:
        c_sum = x[DC_CU] + x[DC_CL]
        dv = q_m / c_sum
        x[DC_ES] += x[DC_V] * (q_p + q_m * x[DC_CU] / c_sum)
        x[DC_VL] -= dv
        x[DC_VU] += dv
    else:
        i_s = x[DC_SRC]
        x[DC_IS] = i_s
        q_s = i_s * dt
        v_p0 = x[DC_VU] + x[DC_VL]
        x[DC_VU] += (q_s - q_p) / x[DC_CU]
        x[DC_VL] += (q_s - q_p - q_m) / x[DC_CL]
        x[DC_ES] += 0.5 * (v_p0 + (x[DC_VU] + x[DC_VL])) * q_s


@njit
def shaft_step(load, inertia, friction, w0, te, dt):
    """J dw/dt = T_e - T_L - B w over dt, trapezoidal (load: LD_* settings):
    (w1, w_avg, t_load, friction_energy, load_energy)."""
    mode = int(load[LD_MODE])
    if mode == DYNAMOMETER:
        w1 = load[LD_SPEED]
        w_avg = 0.5 * (w0 + w1)
        t_load = te - friction * w_avg - inertia * (w1 - w0) / dt
    else:
        b_load = load[LD_VISCOUS] if mode == VISCOUS else 0.0
        t_const = load[LD_TORQUE] if mode == TORQUE else 0.0
        b = friction + b_load
        w1 = (inertia * w0 + dt * (te - t_const - 0.5 * b * w0)) / (inertia + 0.5 * b * dt)
        w_avg = 0.5 * (w0 + w1)
        t_load = t_const + b_load * w_avg
    return w1, w_avg, t_load, friction * w_avg * w_avg * dt, t_load * w_avg * dt


@njit
def link_stored_energy(x, mode):
    """Capacitor energy C_u v_u^2 / 2 + C_l v_l^2 / 2 [J] (0 for the ideal source)."""
    if mode == IDEAL:
        return 0.0
    return 0.5 * (x[DC_CU] * libm_pow(x[DC_VU], 2.0) + x[DC_CL] * libm_pow(x[DC_VL], 2.0))
