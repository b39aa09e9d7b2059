"""Inverter voltage-drop compensation for the voltage-model flux estimator (001 sec. III, Tables III-VI).

The correction added to the ideal alpha/beta voltage is the Clarke transform of
the switched legs' drops (-v_fx - R_on i_x), v_fx by switch state and current sign
(001 eq. 20, Table III); the midpoint phase has no device. 001 eqs. (26) and (37)
print the R_on alpha term with a wrong sign (the circuit test pins this).
Schemes: 'none'; 'simple' = Table V (one drop, current signs only); 'proposed' =
Table VI plus the R_on terms of eqs. (37)-(38). Values change at runtime
(attributes). Derivation: docs/models.md "Inverter voltage-drop compensation".
"""
from __future__ import annotations

from drive_common.compiled import interpreted, njit
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


_leg_drop = interpreted(leg_drop)                 # the class's per-call path (no dispatch cost)
_drop_correction = interpreted(drop_correction)


class VoltageDropCompensation:
    """Correction (dv_alpha, dv_beta) [V] to add to the ideal inverter voltage.

    midpoint_phase: index of the phase tied to the capacitor midpoint (0 = a,
    as in 001), or None for the six-switch inverter (all legs drop).
    scheme, v_ce, v_d, v_f [V], r_on [ohm] may be changed between samples.
    """

    __slots__ = ('midpoint_phase', 'scheme', 'v_ce', 'v_d', 'v_f', 'r_on', '_legs')

    def __init__(self, midpoint_phase: int | None = 0, scheme: str = 'none', v_ce: float = 0.9,
                 v_d: float = 1.25, v_f: float = 0.9, r_on: float = 0.075) -> None:
        self.midpoint_phase = midpoint_phase
        self._legs = tuple(x for x in range(3) if x != midpoint_phase)
        self.configure(scheme, v_ce, v_d, v_f, r_on)

    def configure(self, scheme: str, v_ce: float, v_d: float, v_f: float, r_on: float) -> None:
        if scheme not in SCHEMES:
            raise ValueError(f'voltage-drop compensation {scheme!r} is not one of {SCHEMES}')
        self.scheme = scheme
        self.v_ce, self.v_d, self.v_f, self.r_on = float(v_ce), float(v_d), float(v_f), float(r_on)

    def leg_drops(self, switch_on: tuple, currents: tuple) -> tuple[float, float, float]:
        """Drop v_fx + R_on i_x [V] of each leg the scheme assumes (0 for the midpoint phase)."""
        out = [0.0, 0.0, 0.0]
        scheme = self.scheme
        if scheme == 'none':
            return tuple(out)
        simple = scheme == 'simple'
        for x in self._legs:
            out[x] = _leg_drop(simple, bool(switch_on[2 * x]), currents[x], self.v_ce, self.v_d, self.v_f,
                               self.r_on)
        return tuple(out)

    def correction(self, switch_on: tuple, currents: tuple) -> tuple[float, float]:
        """(dv_alpha, dv_beta) [V] = Clarke of the negated leg drops; add to the ideal voltage."""
        if self.scheme == 'none':
            return 0.0, 0.0
        return _drop_correction(*self.leg_drops(switch_on, currents))


def table_v(v_f: float) -> dict:
    """001 Table V from the formulas: {(sign i_b, sign i_c): (v_falpha, v_fbeta)}, phase a on the midpoint."""
    comp = VoltageDropCompensation(0, 'simple', v_f=v_f)
    return {(sb, sc): comp.correction((False,) * 6, (0.0, float(sb), float(sc)))
            for sb in (-1, 1) for sc in (-1, 1)}


def table_vi(v_ce: float, v_d: float) -> dict:
    """001 Table VI from the formulas: {(S_B, S_C, sign i_b, sign i_c): (v_falpha, v_fbeta)} (R_on = 0)."""
    comp = VoltageDropCompensation(0, 'proposed', v_ce=v_ce, v_d=v_d, r_on=0.0)
    out = {}
    for s_b in (0, 1):
        for s_c in (0, 1):
            sw = (False, False, bool(s_b), not s_b, bool(s_c), not s_c)
            for sb in (-1, 1):
                for sc in (-1, 1):
                    out[(s_b, s_c, sb, sc)] = comp.correction(sw, (0.0, float(sb), float(sc)))
    return out
