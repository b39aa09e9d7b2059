"""Inverter voltage space vectors derived from the circuit (000 Appendices C and D, Table I).

A vector is a switch tuple ``(SW1..SW6)``; each leg is HIGH, LOW, OPEN or MIDPOINT
(four-switch inverter). The *ideal* vector takes the open-phase back-EMF as zero and
a balanced midpoint (amplitude-invariant Clarke). Derivation: docs/models.md
"Voltage space vectors".
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from itertools import permutations, product

from drive_common.signals import clarke

HIGH, LOW, OPEN, MIDPOINT = 'H', 'L', 'O', 'M'
PHASES = ('a', 'b', 'c')


def leg_states(switch_on, midpoint_phase: int | None = None) -> tuple[str, str, str]:
    """Leg state (HIGH/LOW/OPEN/MIDPOINT) of each phase for a switch tuple; shoot-through raises."""
    legs = []
    for x in range(3):
        if x == midpoint_phase:
            legs.append(MIDPOINT)
            continue
        upper, lower = bool(switch_on[2 * x]), bool(switch_on[2 * x + 1])
        if upper and lower:
            raise ValueError(f'shoot-through: both switches of phase {PHASES[x]} on in {switch_on}')
        legs.append(HIGH if upper else LOW if lower else OPEN)
    return tuple(legs)


def switches_of(legs) -> tuple[bool, ...]:
    """Switch tuple (SW1..SW6) that realises the given leg states (MIDPOINT/OPEN legs off)."""
    return tuple(on for leg in legs for on in (leg == HIGH, leg == LOW))


def phase_voltages(legs, v_dc: float, v_mid: float | None = None,
                   emf=(0.0, 0.0, 0.0)) -> tuple[float, float, float]:
    """Phase voltages [V] of the Y-connected motor for the leg states (conducting currents sum to zero).

    emf: phase back-EMFs [V] (only open phases matter); under two conducting legs each phase is its EMF.
    """
    if v_mid is None:
        v_mid = 0.5 * v_dc
    term = [v_dc if leg == HIGH else 0.0 if leg == LOW else v_mid if leg == MIDPOINT else None
            for leg in legs]
    cond = [x for x in range(3) if term[x] is not None]
    if len(cond) < 2:
        return tuple(float(e) for e in emf)
    open_ = [x for x in range(3) if term[x] is None]
    v_n = (sum(term[x] for x in cond) + sum(emf[x] for x in open_)) / len(cond)
    return tuple((term[x] - v_n) if term[x] is not None else float(emf[x]) for x in range(3))


@lru_cache(maxsize=None)
def voltage_coefficients(legs: tuple) -> tuple:
    """(a_dc, a_mid, b_dc, b_mid, ((x, ka, kb), ...)): v_alpha = a_dc V_dc + a_mid v_mid + sum(ka e_x)
    over open phases x, v_beta likewise (exact, by superposition)."""
    a_dc, b_dc = clarke(*phase_voltages(legs, 1.0, 0.0))
    a_mid, b_mid = clarke(*phase_voltages(legs, 0.0, 1.0))
    terms = []
    for x in range(3):
        if legs[x] == OPEN:
            e = [0.0, 0.0, 0.0]
            e[x] = 1.0
            ka, kb = clarke(*phase_voltages(legs, 0.0, 0.0, e))
            terms.append((x, ka, kb))
    return a_dc, a_mid, b_dc, b_mid, tuple(terms)


@dataclass(frozen=True)
class VoltageVector:
    """One inverter state. alpha/beta: ideal voltage per volt of V_dc (balanced midpoint, open-phase EMF 0)."""

    name: str
    index: int
    switch_on: tuple
    legs: tuple
    alpha: float
    beta: float
    two_phase: bool   # exactly one phase carries no ideal voltage (open, or a balanced midpoint phase)

    @property
    def angle(self) -> float:
        """rad, direction in the alpha/beta plane, [0, 2 pi)."""
        return math.atan2(self.beta, self.alpha) % (2.0 * math.pi)

    @property
    def magnitude(self) -> float:
        """per unit of V_dc."""
        return math.hypot(self.alpha, self.beta)

    def code(self, switches: int = 6) -> str:
        """The dissertation's switch code, e.g. '100001' (6) or '1000' (SW1..SW4)."""
        return ''.join('1' if s else '0' for s in self.switch_on[:switches])

    def voltage(self, v_dc: float, v_mid: float | None = None, emf=(0.0, 0.0, 0.0)) -> tuple[float, float]:
        """alpha/beta voltage [V] from the circuit for the given DC link and open-phase back-EMFs."""
        return clarke(*phase_voltages(self.legs, v_dc, v_mid, emf))


def _make(name: str, index: int, legs: tuple) -> VoltageVector:
    va, vb, vc = phase_voltages(legs, 1.0, 0.5)
    alpha, beta = clarke(va, vb, vc)
    two = sum(1 for v in (va, vb, vc) if abs(v) < 1e-12) == 1 and math.hypot(alpha, beta) > 1e-12
    return VoltageVector(name, index, switches_of(legs), legs, alpha, beta, two)


def _number_by_angle(vectors: list[VoltageVector], first_angle_deg: float, prefix: str = 'V') -> list[VoltageVector]:
    """Number active vectors 1..6 counter-clockwise starting at first_angle_deg (the seeds' numbering)."""
    out = []
    for v in vectors:
        k = round(((math.degrees(v.angle) - first_angle_deg) % 360.0) / 60.0) % 6 + 1
        out.append(VoltageVector(f'{prefix}{k}', k, v.switch_on, v.legs, v.alpha, v.beta, v.two_phase))
    return sorted(out, key=lambda v: v.index)


def two_phase_six_switch_vectors() -> tuple[VoltageVector, ...]:
    """Six-switch two-phase vectors (000 Fig. 2.1, Appendix C): V0 all off, V1..V6 one phase HIGH,
    one LOW, numbered CCW from 30 deg (V1 = '100001' of Table II)."""
    active = [_make('', 0, tuple(HIGH if x == hi else LOW if x == lo else OPEN for x in range(3)))
              for hi, lo in permutations(range(3), 2)]
    zero = _make('V0', 0, (OPEN, OPEN, OPEN))
    return (zero, *_number_by_angle(active, 30.0))


def four_switch_vectors(midpoint_phase: int = 2) -> tuple[VoltageVector, ...]:
    """Four-switch inverter, phase `midpoint_phase` on the capacitor midpoint (000 Fig. 4.3, Table IV).

    Two-phase vectors V1..V6 CCW from 30 deg (V1 = '1000'); both switched legs HIGH is V0, both LOW
    V7 (000 Table V, Fig. 4.5; Appendix D swaps the two and misprints V2 and V5).
    """
    switched = [x for x in range(3) if x != midpoint_phase]
    active, extra = [], []
    for s0, s1 in product((HIGH, LOW, OPEN), repeat=2):
        if s0 != OPEN or s1 != OPEN:
            legs = [MIDPOINT] * 3
            legs[switched[0]], legs[switched[1]] = s0, s1
            if s0 == s1:
                extra.append(_make('V0' if s0 == HIGH else 'V7', 0 if s0 == HIGH else 7, tuple(legs)))
            else:
                active.append(_make('', 0, tuple(legs)))
    return (*_number_by_angle(active, 30.0), *sorted(extra, key=lambda v: v.index))


def three_phase_six_switch_vectors() -> tuple[VoltageVector, ...]:
    """Conventional six-switch vectors (000 Table I): V1(100) at 0 deg ... V6(101), V0(000), V7(111);
    leg x is HIGH when S_x = 1, else LOW."""
    active, zeros = [], []
    for bits in product((0, 1), repeat=3):  # S_a S_b S_c
        legs = tuple(HIGH if b else LOW for b in bits)
        if len(set(bits)) == 1:
            zeros.append(_make(f'V{7 * bits[0]}', 7 * bits[0], legs))
        else:
            active.append(_make('', 0, legs))
    return (*_number_by_angle(active, 0.0), *zeros)


def by_name(vectors) -> dict[str, VoltageVector]:
    """{name: vector}."""
    return {v.name: v for v in vectors}
