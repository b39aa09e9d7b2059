"""Three-phase conduction switching tables, derived from the circuit and the seeds' rules.

Six-switch (000 Table I, PMSM; Table VI, BLDC DTIFC): six 60-deg sectors centred on V_i; the
printed tables misprint most switch codes (:data:`PRINTED_000_TABLE_I`). Four-switch (001 Tables
I-II, phase a on the midpoint): four vectors, four 90-deg sectors, sector I = [0, 90) deg. Both by
:func:`switching_tables.derive_flux_table`. Corrections: docs/models.md "Three-phase switching
tables".
"""
from __future__ import annotations

import math
from itertools import product

from drive_common.compiled import njit
from drive_common.signals import clarke

from .switching_tables import derive_flux_table, sector_of_angle
from .vectors import HIGH, LOW, MIDPOINT, VoltageVector, phase_voltages, switches_of, \
    three_phase_six_switch_vectors

QUARTER = 0.5 * math.pi
TWO_PI = 2.0 * math.pi

# {(phi, tau): [(index, code) for sectors 1..6]}; phi/tau as printed (000 Table I uses 1/0).
PRINTED_000_TABLE_I = {
    (1, 1): [(2, '110'), (3, '010'), (4, '001'), (5, '101'), (6, '110'), (1, '110')],
    (1, 0): [(6, '101'), (1, '100'), (2, '010'), (3, '011'), (4, '110'), (5, '110')],
    (0, 1): [(3, '010'), (4, '011'), (5, '101'), (6, '100'), (1, '110'), (2, '110')],
    (0, 0): [(5, '001'), (6, '101'), (1, '110'), (2, '010'), (3, '110'), (4, '110')],
}
PRINTED_000_TABLE_VI = {(1 if phi else -1, 1 if tau else -1): row
                        for (phi, tau), row in PRINTED_000_TABLE_I.items()}
"""000 Table VI is printed with the same entries as Table I (tau, phi = +-1)."""
# 001 Table II: {(d|psi|, dT): [(index, code S_B S_C) for sectors I..IV]}
PRINTED_001_TABLE_II = {
    (1, 1): [(2, '10'), (3, '11'), (4, '01'), (1, '00')],
    (1, 0): [(1, '00'), (2, '10'), (3, '11'), (4, '01')],
    (0, 1): [(3, '11'), (4, '01'), (1, '00'), (2, '10')],
    (0, 0): [(4, '01'), (1, '00'), (2, '10'), (3, '11')],
}


def six_switch_table(rotation: int = 1) -> dict:
    """{(sector 1..6, phi +-1, tau +-1): VoltageVector} of 000 Table I/VI (corrected), for rotation +-1."""
    return derive_flux_table(three_phase_six_switch_vectors(), rotation, phis=(1, -1), taus=(1, -1),
                             two_phase_only=False)


six_switch_sector = sector_of_angle
"""Sector theta(1..6) of a flux angle [rad]: sector i = [(i-1)60 - 30, (i-1)60 + 30) deg."""


def corrected_000_table() -> dict:
    """000 Table I/VI by the rule in the module doc: {(phi, tau): [(index, code)]}, phi/tau = +-1."""
    codes = {v.index: v.code(6) for v in three_phase_six_switch_vectors()}
    step = {(1, 1): 1, (1, -1): -1, (-1, 1): 2, (-1, -1): -2}
    rows = {}
    for key, k in step.items():
        indexes = [(sector + k) % 6 + 1 for sector in range(6)]
        rows[key] = [(i, codes[i][0::2]) for i in indexes]   # code S_a S_b S_c: the upper switches
    return rows


def fstp_vectors(midpoint_phase: int = 0) -> tuple[VoltageVector, ...]:
    """The four FSTP vectors (001 Table I): switched legs complementary, numbered CCW from 0 deg,
    alpha/beta per volt of V_dc with a balanced midpoint."""
    switched = [x for x in range(3) if x != midpoint_phase]
    out = []
    for s0, s1 in product((LOW, HIGH), repeat=2):
        legs = [MIDPOINT] * 3
        legs[switched[0]], legs[switched[1]] = s0, s1
        legs = tuple(legs)
        al, be = clarke(*phase_voltages(legs, 1.0, 0.5))
        idx = int(round((math.atan2(be, al) % TWO_PI) / QUARTER)) % 4 + 1
        out.append(VoltageVector(f'V{idx}', idx, switches_of(legs), legs, al, be, False))
    return tuple(sorted(out, key=lambda v: v.index))


def fstp_code(vector: VoltageVector, midpoint_phase: int = 0) -> str:
    """001's code of a FSTP vector: upper-switch states of the two switched legs, e.g. '10' = S_B S_C."""
    return ''.join('1' if vector.legs[x] == HIGH else '0' for x in range(3) if x != midpoint_phase)


@njit
def four_sector_of_angle(theta: float) -> int:
    """Sector 1..4 (I..IV) of a flux angle [rad]; sector I = [0, 90) deg."""
    return int((theta % TWO_PI) // QUARTER) % 4 + 1


def four_switch_table(rotation: int = 1, midpoint_phase: int = 0) -> dict:
    """{(sector 1..4, phi +-1, tau +-1): VoltageVector}: 001 Table II derived from the rules."""
    centers = [(sector - 0.5) * QUARTER for sector in (1, 2, 3, 4)]   # 45 + 90 (sector - 1) deg
    return derive_flux_table(fstp_vectors(midpoint_phase), rotation, phis=(1, -1), taus=(1, -1),
                             two_phase_only=False, centers=centers)


def corrected_001_table_ii() -> dict:
    """001 Table II in its own notation {(d|psi|, dT) in {0,1}: [(index, code)]} from the derivation."""
    t = four_switch_table(1)
    rows = {}
    for dpsi, dt in product((1, 0), repeat=2):
        vectors = [t[(sector, 2 * dpsi - 1, 2 * dt - 1)] for sector in (1, 2, 3, 4)]
        rows[(dpsi, dt)] = [(v.index, fstp_code(v)) for v in vectors]
    return rows


def printed_000_typos() -> list[str]:
    """Human list of 000 Table I / VI entries whose printed switch code disagrees with the derivation."""
    good = corrected_000_table()
    out = []
    for (phi, tau), row in PRINTED_000_TABLE_I.items():
        key = (1 if phi else -1, 1 if tau else -1)
        for sector, (printed, derived) in enumerate(zip(row, good[key]), start=1):
            if printed != derived:
                out.append(f'phi={phi} tau={tau} theta({sector}): printed V{printed[0]}({printed[1]}), '
                           f'circuit V{derived[0]}({derived[1]})')
    return out

