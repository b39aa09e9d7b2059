"""Six- or four-switch voltage-source inverter with free-wheeling diodes (000 ch. II/IV, 001).

Each leg is driven by its own two gates (SW1/SW2 = a, SW3/SW4 = b, SW5/SW6 = c).
Leg codes: UPPER (upper switch on), LOWER, OFF (both off) and MIDPOINT (the
four-switch inverter's phase tied to the split-capacitor midpoint; its gates
are ignored). Both switches of a leg on would short the link: the gate
driver's interlock turns both off instead (reported as applied = off), and the
plant records it as a shoot-through fault (:meth:`Inverter.shoot_through_legs`).

Device model (001 Tables III/IV): a conducting switch drops V_CE + R_on |i|,
a conducting diode V_d + R_on |i|; which one conducts follows the current
sign. At zero current a leg with a non-zero blocking band is a true open
phase: it carries no current while its floating terminal voltage
v_n + e_x stays inside the band, and starts conducting (diode or switch
threshold) once it leaves it:
  both off: [-V_d, V_P + V_d]; upper on: [V_P - V_CE, V_P + V_d];
  lower on: [-V_d, V_CE]; an ideal switched leg (V_CE = V_d = 0) always conducts.
The resistive part R_on i is held at its segment-start value within an
integration segment (a constant source, so energy accounting stays exact).
"""
from __future__ import annotations

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

    # ------------------------------------------------------------------ gates
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
        out = []
        for code in legs:
            out += [code == UPPER, code == LOWER]
        return tuple(out)

    @staticmethod
    def dead_time_legs(old, new) -> tuple:
        """Legs during the dead time after a change old -> new: each turn-on is delayed."""
        return tuple(n if n == o or n in (OFF, MIDPOINT) else OFF for o, n in zip(old, new))

    # ------------------------------------------------------------------ conduction
    def resolve(self, legs, i, e, vp: float, vm: float):
        """Conduction state for phase currents i and EMFs e (constant over a segment).

        Returns (cond, u, vn, rail): cond[x] whether phase x conducts; u[x] its
        terminal voltage minus e_x [V]; vn the star-point voltage above the
        negative rail [V]; rail[x] the DC node the phase connects to.
        Conducting phases obey (L - M) di_x/dt = u_x - v_n - R i_x with
        v_n = mean of u over the conducting phases (sum of currents is zero).
        """
        vce, vd, ron = self.v_ce, self.v_d, self.r_on
        cond = [False, False, False]
        u = [0.0, 0.0, 0.0]
        rail = [RAIL_N, RAIL_N, RAIL_N]
        floating = []
        for x in (0, 1, 2):
            code = legs[x]
            ix = i[x]
            if code == MIDPOINT:
                cond[x] = True
                u[x] = vm - e[x]
                rail[x] = RAIL_M
                continue
            if ix > 0.0:
                if code == UPPER:
                    t = vp - vce - ron * ix
                    rail[x] = RAIL_P
                else:
                    t = -vd - ron * ix
            elif ix < 0.0:
                if code == LOWER:
                    t = vce - ron * ix
                else:
                    t = vp + vd - ron * ix
                    rail[x] = RAIL_P
            else:
                if code == UPPER:
                    lo, hi, rail_lo, rail_hi = vp - vce, vp + vd, RAIL_P, RAIL_P
                elif code == LOWER:
                    lo, hi, rail_lo, rail_hi = -vd, vce, RAIL_N, RAIL_N
                else:
                    lo, hi, rail_lo, rail_hi = -vd, vp + vd, RAIL_N, RAIL_P
                if hi > lo:
                    floating.append((x, lo, hi, rail_lo, rail_hi))
                    continue
                t = lo
                rail[x] = rail_lo
            cond[x] = True
            u[x] = t - e[x]
        n = cond[0] + cond[1] + cond[2]
        while True:
            if n >= 2:
                vn = (u[0] * cond[0] + u[1] * cond[1] + u[2] * cond[2]) / n
            elif n == 1:
                vn = u[0] if cond[0] else u[1] if cond[1] else u[2]
            else:
                vn = self._open_circuit_neutral(floating, e, vp, cond, u, rail)
                n = cond[0] + cond[1] + cond[2]
                if n:
                    floating = [f for f in floating if not cond[f[0]]]
                    continue
                return cond, u, vn, rail
            if not floating:
                return cond, u, vn, rail
            # Add the most forward-biased open leg (if any), then re-solve v_n.
            worst, excess = None, 0.0
            for f in floating:
                term = vn + e[f[0]]
                over = max(term - f[2], f[1] - term)
                if over > excess:
                    worst, excess = f, over
            if worst is None:
                return cond, u, vn, rail
            x, lo, hi, rail_lo, rail_hi = worst
            if vn + e[x] > hi:
                u[x], rail[x] = hi - e[x], rail_hi
            else:
                u[x], rail[x] = lo - e[x], rail_lo
            cond[x] = True
            n += 1
            floating.remove(worst)

    @staticmethod
    def _open_circuit_neutral(floating, e, vp, cond, u, rail) -> float:
        """No phase conducts: v_n floats; a pair of diodes conducts if the EMFs force it."""
        if len(floating) < 2:
            return 0.5 * vp - (e[0] + e[1] + e[2]) / 3.0
        neg = min(floating, key=lambda f: f[2] - e[f[0]])   # needs v_n > hi - e to conduct (i < 0)
        pos = max(floating, key=lambda f: f[1] - e[f[0]])   # needs v_n < lo - e to conduct (i > 0)
        upper_bound, lower_bound = neg[2] - e[neg[0]], pos[1] - e[pos[0]]
        if upper_bound < lower_bound and neg[0] != pos[0]:
            for f, t, r in ((neg, neg[2], neg[4]), (pos, pos[1], pos[3])):
                cond[f[0]], u[f[0]], rail[f[0]] = True, t - e[f[0]], r
            return 0.5 * (u[neg[0]] + u[pos[0]])
        vn = 0.5 * vp - (e[0] + e[1] + e[2]) / 3.0
        return min(max(vn, lower_bound), upper_bound)
