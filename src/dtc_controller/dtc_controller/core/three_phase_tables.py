"""Three-phase conduction switching tables, derived from the circuit and the seeds' rules.

Six-switch (000 Table I, PMSM; Table VI, BLDC DTIFC): six 60-deg sectors centred
on V_i, the rule of 000 Fig. 1.9 with its text typos corrected; the printed
tables misprint most switch codes (:data:`PRINTED_000_TABLE_I`), the vector index
fixes them. Four-switch three-phase (001 Tables I-II, phase a on the midpoint):
four vectors, four 90-deg sectors with sector I = [0, 90) deg. Both come from
the same derivation (:func:`switching_tables.derive_flux_table`); CW mirrors CCW.
Derivation and corrections: docs/models.md "Three-phase switching tables".
"""
from __future__ import annotations

import math

from drive_common.compiled import njit
from drive_common.signals import clarke

from .switching_tables import derive_flux_table, sector_of_angle, select_vector
from .vectors import HIGH, LOW, MIDPOINT, VoltageVector, phase_voltages, switches_of, \
    three_phase_six_switch_vectors

QUARTER = 0.5 * math.pi
TWO_PI = 2.0 * math.pi

# ----------------------------------------------------------------- printed seed tables (OCR)
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


# ----------------------------------------------------------------- six-switch (000 Tables I, VI)
def six_switch_table(rotation: int = 1) -> dict:
    """{(sector 1..6, phi +-1, tau +-1): VoltageVector} of 000 Table I/VI (corrected), for rotation +-1."""
    return derive_flux_table(three_phase_six_switch_vectors(), rotation, phis=(1, -1), taus=(1, -1),
                             two_phase_only=False)


def six_switch_sector(theta: float) -> int:
    """Sector theta(1..6) of a flux angle [rad]: sector i = [(i-1)60 - 30, (i-1)60 + 30) deg."""
    return sector_of_angle(theta)


def corrected_000_table() -> dict:
    """000 Table I/VI by the rule in the module doc: {(phi, tau): [(index, code)]}, phi/tau = +-1."""
    codes = {v.index: v.code(6) for v in three_phase_six_switch_vectors()}
    step = {(1, 1): 1, (1, -1): -1, (-1, 1): 2, (-1, -1): -2}
    out = {}
    for key, k in step.items():
        row = []
        for sector in range(1, 7):
            idx = (sector - 1 + k) % 6 + 1
            row.append((idx, _sa_sb_sc(codes[idx])))
        out[key] = row
    return out


def _sa_sb_sc(code6: str) -> str:
    """'100001' (SW1..SW6) -> '100' (S_a S_b S_c = upper switch states)."""
    return code6[0] + code6[2] + code6[4]


# ----------------------------------------------------------------- four-switch (001 Tables I, II)
def fstp_vectors(midpoint_phase: int = 0) -> tuple[VoltageVector, ...]:
    """The four FSTP vectors (001 Table I): switched legs complementary, numbered CCW from 0 deg.

    alpha/beta per volt of V_dc from the circuit (:func:`vectors.phase_voltages`,
    balanced midpoint V_dc/2); ``code(6)`` gives SW1..SW6, :func:`fstp_code` the S_B S_C code.
    """
    switched = [x for x in range(3) if x != midpoint_phase]
    out = []
    for s0 in (LOW, HIGH):
        for s1 in (LOW, HIGH):
            legs = [MIDPOINT] * 3
            legs[switched[0]], legs[switched[1]] = s0, s1
            legs = tuple(legs)
            al, be = clarke(*phase_voltages(legs, 1.0, 0.5))
            ang = math.atan2(be, al) % TWO_PI
            idx = int(round(ang / QUARTER)) % 4 + 1
            out.append(VoltageVector(f'V{idx}', idx, switches_of(legs), legs, al, be, False))
    return tuple(sorted(out, key=lambda v: v.index))


def fstp_code(vector: VoltageVector, midpoint_phase: int = 0) -> str:
    """001's code of a FSTP vector: upper-switch states of the two switched legs, e.g. '10' = S_B S_C."""
    return ''.join('1' if vector.legs[x] == HIGH else '0' for x in range(3) if x != midpoint_phase)


def four_sector_center(sector: int) -> float:
    """rad, centre of 90-deg sector I..IV (1..4): 45 + 90 (sector - 1) deg."""
    return (sector - 0.5) * QUARTER


@njit
def four_sector_of_angle(theta: float) -> int:
    """Sector 1..4 (I..IV) of a flux angle [rad]; sector I = [0, 90) deg."""
    return int((theta % TWO_PI) // QUARTER) % 4 + 1


def four_switch_table(rotation: int = 1, midpoint_phase: int = 0) -> dict:
    """{(sector 1..4, phi +-1, tau +-1): VoltageVector}: 001 Table II derived from the rules."""
    vecs = fstp_vectors(midpoint_phase)
    table = {}
    for sector in (1, 2, 3, 4):
        c = four_sector_center(sector)
        for phi in (1, -1):
            for tau in (1, -1):
                table[(sector, phi, tau)] = select_vector(vecs, c, rotation * tau, phi)
    return table


def corrected_001_table_ii() -> dict:
    """001 Table II in its own notation {(d|psi|, dT) in {0,1}: [(index, code)]} from the derivation."""
    t = four_switch_table(1)
    out = {}
    for dpsi in (1, 0):
        for dt in (1, 0):
            row = []
            for sector in (1, 2, 3, 4):
                v = t[(sector, 1 if dpsi else -1, 1 if dt else -1)]
                row.append((v.index, fstp_code(v)))
            out[(dpsi, dt)] = row
    return out


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

