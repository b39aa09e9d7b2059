"""Inverter voltage-drop compensation of the voltage-model flux estimator (001 sec. III, Tables III-VI).

The correction is the Clarke transform of the switched legs' drops (-v_fx - R_on i_x), v_fx by
switch state and current sign (001 eq. 20, Table III). Schemes: 'none'; 'simple' = Table V;
'proposed' = Table VI plus the R_on terms of eqs. (37)-(38), whose alpha term 001 prints with the
wrong sign. Derivation: docs/models.md "Inverter voltage-drop compensation".
"""
from __future__ import annotations

from drive_common.compiled import njit
from drive_common.signals import INV_SQRT3

SCHEMES = ('none', 'simple', 'proposed')


@njit
def forward_drop(upper_on: bool, current: float, v_ce: float, v_d: float) -> float:
    """001 Table III: forward voltage drop v_f [V] of one leg (positive = terminal below the ideal)."""
    if current > 0.0:
        return v_ce if upper_on else v_d
    if current < 0.0:
        return -v_d if upper_on else -v_ce
    return 0.0


def leg_terminal_voltage(upper_on: bool, current: float, v_dc: float, v_ce: float, v_d: float,
                         r_on: float) -> float:
    """Device model (001 eq. 20, Tables III-IV): terminal voltage [V] above the negative rail."""
    return (v_dc if upper_on else 0.0) - forward_drop(upper_on, current, v_ce, v_d) - r_on * current


@njit
def leg_drop(simple: bool, upper_on: bool, current: float, v_ce: float, v_d: float, v_f: float,
             r_on: float) -> float:
    """Drop [V] the scheme assumes on one switched leg: Table V's v_f sign(i) (simple), or Table III's
    v_f plus R_on i (proposed)."""
    if simple:
        return v_f * (1.0 if current > 0.0 else -1.0 if current < 0.0 else 0.0)
    return forward_drop(upper_on, current, v_ce, v_d) + r_on * current


@njit
def drop_correction(d_a: float, d_b: float, d_c: float) -> tuple[float, float]:
    """(dv_alpha, dv_beta) [V]: Clarke of the negated leg drops d_x [V] (add to the ideal voltage)."""
    return (d_b + d_c - 2.0 * d_a) / 3.0, (d_c - d_b) * INV_SQRT3


@njit
def correction(scheme: int, midpoint: int, upper_a: bool, upper_b: bool, upper_c: bool, i_a: float,
               i_b: float, i_c: float, v_ce: float, v_d: float, v_f: float, r_on: float) -> tuple[float, float]:
    """(dv_alpha, dv_beta) [V] to add to the ideal voltage: scheme by its position in SCHEMES, upper
    switch and current [A] of each leg, the midpoint phase (-1: none) without a drop."""
    if scheme == 0:
        return 0.0, 0.0
    upper = (upper_a, upper_b, upper_c)
    cur = (i_a, i_b, i_c)
    d = [0.0, 0.0, 0.0]
    for x in range(3):
        if x != midpoint:
            d[x] = leg_drop(scheme == 1, upper[x], cur[x], v_ce, v_d, v_f, r_on)
    return drop_correction(d[0], d[1], d[2])
