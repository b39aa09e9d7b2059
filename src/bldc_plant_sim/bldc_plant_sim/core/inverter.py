"""Six- or four-switch voltage-source inverter with free-wheeling diodes (000 ch. II/IV, 001).

Gates SW1/SW2 = leg a, SW3/SW4 = b, SW5/SW6 = c. Leg codes: UPPER, LOWER, OFF and MIDPOINT
(the four-switch inverter's phase tied to the capacitor midpoint). Both switches of a leg on:
the interlock turns both off (a shoot-through fault). Devices drop V_CE or V_d + R_on |i|
(001 Tables III/IV); at zero current a leg is open while inside its blocking band
(docs/models.md "Inverter").
"""
from __future__ import annotations

from drive_common.compiled import njit

UPPER, LOWER, OFF, MIDPOINT = 1, -1, 0, 2
RAIL_N, RAIL_P, RAIL_M = 0, 1, 2
PHASES = 'abc'


class Inverter:
    """Switch logic and the conduction state of the legs for given currents and EMFs."""

    def __init__(self, topology: int, midpoint_phase: str = 'c', v_ce: float = 0.0,
                 v_d: float = 0.0, r_on: float = 0.0, dead_time: float = 0.0) -> None:
        if topology not in (4, 6):
            raise ValueError(f'inverter topology must be 4 or 6, got {topology}')
        self.topology = topology
        self.midpoint = PHASES.index(midpoint_phase) if topology == 4 else -1
        self.dead_time = dead_time
        self.set_drops(v_ce, v_d, r_on)

    @classmethod
    def from_params(cls, p: dict) -> 'Inverter':
        return cls(p['inverter.topology'], p['inverter.midpoint_phase'], p['inverter.v_ce'],
                   p['inverter.v_d'], p['inverter.r_on'], p['inverter.dead_time'])

    def set_drops(self, v_ce: float, v_d: float, r_on: float) -> None:
        self.v_ce, self.v_d, self.r_on = float(v_ce), float(v_d), float(r_on)

    def legs(self, switch_on) -> tuple:
        """Leg codes from the six gate signals (interlock; midpoint leg fixed)."""
        out = []
        for x in range(3):
            if x == self.midpoint:
                out.append(MIDPOINT)
                continue
            up, low = switch_on[2 * x], switch_on[2 * x + 1]
            out.append(UPPER if up and not low else LOWER if low and not up else OFF)
        return tuple(out)

    def shoot_through_legs(self, switch_on) -> str:
        """The legs ('a', 'b', 'c') whose two switches are both commanded on ('' = none)."""
        return ''.join(PHASES[x] for x in range(3)
                       if x != self.midpoint and switch_on[2 * x] and switch_on[2 * x + 1])

    def all_off(self) -> tuple:
        return tuple(MIDPOINT if x == self.midpoint else OFF for x in range(3))

    @staticmethod
    def switches(legs) -> tuple:
        """Applied (SW1..SW6) of leg codes."""
        return tuple(on for code in legs for on in (code == UPPER, code == LOWER))


@njit
def _leg_start(code, ix, ex, vp, vm, vce, vd, ron, fl):
    """Leg x at current ix: (conducts, u_x, rail), or a blocking band [lo, hi] stored in fl
    (lo, hi, rail_lo, rail_hi) when it is open at zero current (module docstring)."""
    if code == MIDPOINT:
        return True, vm - ex, RAIL_M
    rail = RAIL_N
    if ix > 0.0:
        if code == UPPER:
            t = vp - vce - ron * ix
            rail = RAIL_P
        else:
            t = -vd - ron * ix
    elif ix < 0.0:
        if code == LOWER:
            t = vce - ron * ix
        else:
            t = vp + vd - ron * ix
            rail = RAIL_P
    else:
        if code == UPPER:
            lo, hi, rail_lo, rail_hi = vp - vce, vp + vd, RAIL_P, RAIL_P
        elif code == LOWER:
            lo, hi, rail_lo, rail_hi = -vd, vce, RAIL_N, RAIL_N
        else:
            lo, hi, rail_lo, rail_hi = -vd, vp + vd, RAIL_N, RAIL_P
        if hi > lo:
            fl[0], fl[1], fl[2], fl[3] = lo, hi, rail_lo, rail_hi
            return False, 0.0, RAIL_N
        t = lo
        rail = rail_lo
    return True, t - ex, rail


@njit
def resolve_legs(legs, i, e, vp, vm, vce, vd, ron, cond, u, rail, band, floating):
    """Conduction state of the legs for currents i, EMFs e: cond, u (terminal voltage - e_x),
    rail written in place, v_n returned (mean of u over the conducting phases); open legs join,
    most forward-biased first. Zeroed scratch: band (lo, hi, rail_lo, rail_hi per open leg) and
    floating (1 while a leg is open at zero current)."""
    for x in range(3):
        c, ux, r = _leg_start(legs[x], i[x], e[x], vp, vm, vce, vd, ron, band[x])
        cond[x], u[x], rail[x] = c, ux, r
        floating[x] = 0 if c else 1
    n = cond[0] + cond[1] + cond[2]
    while True:
        if n >= 2:
            vn = (u[0] * cond[0] + u[1] * cond[1] + u[2] * cond[2]) / n
        elif n == 1:
            vn = u[0] if cond[0] else u[1] if cond[1] else u[2]
        else:
            vn = _open_circuit_neutral(floating, band, e, vp, cond, u, rail)
            n = cond[0] + cond[1] + cond[2]
            if n:
                for x in range(3):
                    if cond[x]:
                        floating[x] = 0
                continue
            return vn
        # Add the most forward-biased open leg (if any), then re-solve v_n.
        worst, excess = -1, 0.0
        for x in range(3):
            if floating[x]:
                term = vn + e[x]
                over = max(term - band[x, 1], band[x, 0] - term)
                if over > excess:
                    worst, excess = x, over
        if worst < 0:
            return vn
        x = worst
        if vn + e[x] > band[x, 1]:
            u[x], rail[x] = band[x, 1] - e[x], int(band[x, 3])
        else:
            u[x], rail[x] = band[x, 0] - e[x], int(band[x, 2])
        cond[x] = 1
        n += 1
        floating[x] = 0


@njit
def _open_circuit_neutral(floating, band, e, vp, cond, u, rail):
    """No phase conducts: v_n floats; a pair of diodes conducts if the EMFs force it."""
    count = floating[0] + floating[1] + floating[2]
    if count < 2:
        return 0.5 * vp - (e[0] + e[1] + e[2]) / 3.0
    neg, pos = -1, -1     # first minimum of hi - e (needs v_n above it, i < 0), max of lo - e
    for x in range(3):
        if floating[x]:
            if neg < 0 or band[x, 1] - e[x] < band[neg, 1] - e[neg]:
                neg = x
            if pos < 0 or band[x, 0] - e[x] > band[pos, 0] - e[pos]:
                pos = x
    upper_bound, lower_bound = band[neg, 1] - e[neg], band[pos, 0] - e[pos]
    if upper_bound < lower_bound and neg != pos:
        cond[neg], u[neg], rail[neg] = 1, band[neg, 1] - e[neg], int(band[neg, 3])
        cond[pos], u[pos], rail[pos] = 1, band[pos, 0] - e[pos], int(band[pos, 2])
        return 0.5 * (u[neg] + u[pos])
    vn = 0.5 * vp - (e[0] + e[1] + e[2]) / 3.0
    return min(max(vn, lower_bound), upper_bound)
