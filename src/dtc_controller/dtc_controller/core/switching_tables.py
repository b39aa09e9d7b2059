"""Switching tables derived from the vector geometry and the seeds' stated rules.

Six 60-deg sectors, sector 1 = [-30, 30) deg. tau = +1 turns the stator flux in the commanded
direction, phi = +1/-1/0 raises, lowers or keeps its amplitude at the sector centre; among the
candidates the largest tangential component wins. This reproduces 000 Tables II, IV and V
(four-switch sectors II and V by phase-torque comparators). Rules: docs/models.md "Two-phase
switching tables".
"""
from __future__ import annotations

import math

from drive_common.compiled import njit

from .vectors import HIGH, LOW, OPEN, VoltageVector

SECTOR_WIDTH = math.pi / 3.0
SECTORS = (1, 2, 3, 4, 5, 6)
_EPS = 1e-9


def sector_center(sector: int) -> float:
    """rad, centre angle of sector 1..6."""
    return (sector - 1) * SECTOR_WIDTH


@njit
def sector_of_angle(theta: float) -> int:
    """Sector 1..6 containing angle theta [rad] (sector 1 = [-30, 30) deg)."""
    return int(((theta + 0.5 * SECTOR_WIDTH) % (2.0 * math.pi)) // SECTOR_WIDTH) % 6 + 1


def components(vector: VoltageVector, flux_angle: float) -> tuple[float, float]:
    """(radial, tangential-CCW) components of a vector's ideal direction relative to a flux at flux_angle."""
    c, s = math.cos(flux_angle), math.sin(flux_angle)
    return vector.alpha * c + vector.beta * s, -vector.alpha * s + vector.beta * c


def select_vector(candidates, flux_angle: float, tangential_sign: int, radial_sign: int) -> VoltageVector:
    """The vector meeting the tangential/radial sign rules at flux_angle (module doc); ValueError if none."""
    tol = 1e-6 * max(v.magnitude for v in candidates)
    found = []
    for v in candidates:
        radial, tang = components(v, flux_angle)
        radial_ok = abs(radial) <= tol if radial_sign == 0 else radial * radial_sign > tol
        if tang * tangential_sign > tol and radial_ok:
            found.append((tang * tangential_sign, abs(radial), v))
    if not found:
        raise ValueError(f'no vector turns the flux with sign {tangential_sign} and radial sign '
                         f'{radial_sign} at {math.degrees(flux_angle):.1f} deg')
    return max(found, key=lambda t: t[:2])[2]   # the largest tangential, then radial, component


def derive_flux_table(vectors, rotation: int = 1, phis=(1, 0, -1), taus=(1, -1),
                      two_phase_only: bool = True, centers=None) -> dict:
    """{(sector, phi, tau): VoltageVector} by the module doc's rules (Tables II and IV); centers [rad]
    of sectors 1, 2, ... (default: the six 60-deg sectors)."""
    cands = [v for v in vectors if v.magnitude > _EPS and (v.two_phase or not two_phase_only)]
    table = {}
    for sector, center in enumerate(centers or map(sector_center, SECTORS), start=1):
        for phi in phis:
            for tau in taus:
                table[(sector, phi, tau)] = select_vector(cands, center, rotation * tau, phi)
    return table


def k_sign(phase: int, theta: float) -> int:
    """Sign of the fundamental of k_x(theta) = -sin(theta - 2 pi x / 3) (docs/architecture.md)."""
    return 1 if -math.sin(theta - phase * 2.0 * math.pi / 3.0) > 0.0 else -1


def split_phase_sectors(table: dict, midpoint_phase: int) -> tuple[int, ...]:
    """Sectors whose phi = 0 vectors drive the two switched legs against each other (midpoint phase idle).

    For phase c on the midpoint these are sectors II and V (000 Table III: T_ec = 0 there).
    """
    out = []
    for sector in SECTORS:
        legs = table[(sector, 0, 1)].legs
        switched = [legs[x] for x in range(3) if x != midpoint_phase]
        if OPEN not in switched:
            out.append(sector)
    return tuple(out)


def derive_split_phase_table(vectors, midpoint_phase: int, sectors, rotation: int = 1) -> dict:
    """{(sector, tau_first, tau_second): VoltageVector} for phase-torque control (Table V); the taus
    belong to the two switched phases in a, b, c order."""
    by_legs = {v.legs: v for v in vectors}
    switched = [x for x in range(3) if x != midpoint_phase]
    table = {}
    for sector in sectors:
        center = sector_center(sector)
        for t0 in (1, -1):
            for t1 in (1, -1):
                legs = ['M'] * 3
                for x, tau in zip(switched, (t0, t1)):
                    legs[x] = HIGH if rotation * tau * k_sign(x, center) > 0 else LOW
                table[(sector, t0, t1)] = by_legs[tuple(legs)]
    return table

