"""Switching tables: derived from geometry + rules; each entry checked for its effect."""
import math

import numpy as np
import pytest

from dtc_controller.core import switching_tables as st
from dtc_controller.core import vectors as vx
from dtc_test_tables import make_table

SIX = vx.two_phase_six_switch_vectors()
FOUR = vx.four_switch_vectors(2)
SECTOR_ANGLES = np.radians(np.linspace(-29.0, 29.0, 59))  # interior of a sector, relative to its centre


def row(table, phi, tau, switches=6):
    return [f'{table[(s, phi, tau)].name}({table[(s, phi, tau)].code(switches)})' for s in st.SECTORS]


def test_table_ii_ccw_matches_seed():
    t = st.derive_flux_table(SIX, rotation=1)
    seed = {  # 000 Table II (this one printed consistently in the OCR text)
        (1, 1): 'V1(100001) V2(001001) V3(011000) V4(010010) V5(000110) V6(100100)',
        (1, -1): 'V6(100100) V1(100001) V2(001001) V3(011000) V4(010010) V5(000110)',
        (0, 1): 'V2(001001) V3(011000) V4(010010) V5(000110) V6(100100) V1(100001)',
        (0, -1): 'V5(000110) V6(100100) V1(100001) V2(001001) V3(011000) V4(010010)',
        (-1, 1): 'V3(011000) V4(010010) V5(000110) V6(100100) V1(100001) V2(001001)',
        (-1, -1): 'V4(010010) V5(000110) V6(100100) V1(100001) V2(001001) V3(011000)',
    }
    for (phi, tau), text in seed.items():
        assert ' '.join(row(t, phi, tau)) == text


def test_table_iv_ccw_matches_seed():
    t = st.derive_flux_table(FOUR, rotation=1)
    assert ' '.join(row(t, 0, 1, 4)) == 'V2(0010) V3(0110) V4(0100) V5(0001) V6(1001) V1(1000)'
    assert ' '.join(row(t, 0, -1, 4)) == 'V5(0001) V6(1001) V1(1000) V2(0010) V3(0110) V4(0100)'
    assert ' '.join(row(t, 1, 1, 4)) == 'V1(1000) V2(0010) V3(0110) V4(0100) V5(0001) V6(1001)'
    assert ' '.join(row(t, -1, -1, 4)) == 'V4(0100) V5(0001) V6(1001) V1(1000) V2(0010) V3(0110)'


def test_table_i_classical_matches_seed_after_typo_fix():
    t = st.derive_flux_table(vx.three_phase_six_switch_vectors(), 1, phis=(1, -1), two_phase_only=False)
    # Table I with tau = 0 read as -1 and phi = 0 as -1; the printed codes V6(110), V1(110)... are typos
    assert [t[(s, 1, 1)].name for s in st.SECTORS] == ['V2', 'V3', 'V4', 'V5', 'V6', 'V1']
    assert [t[(s, 1, -1)].name for s in st.SECTORS] == ['V6', 'V1', 'V2', 'V3', 'V4', 'V5']
    assert [t[(s, -1, 1)].name for s in st.SECTORS] == ['V3', 'V4', 'V5', 'V6', 'V1', 'V2']
    assert [t[(s, -1, -1)].name for s in st.SECTORS] == ['V5', 'V6', 'V1', 'V2', 'V3', 'V4']


@pytest.mark.parametrize('vectors', [SIX, FOUR], ids=['six', 'four'])
@pytest.mark.parametrize('rotation', [1, -1])
def test_every_entry_turns_flux_as_commanded_over_whole_sector(vectors, rotation):
    t = st.derive_flux_table(vectors, rotation)
    for (sector, phi, tau), v in t.items():
        for rel in SECTOR_ANGLES:
            radial, tang = st.components(v, st.sector_center(sector) + rel)
            # tau = +1 advances the flux in the commanded direction, -1 retards it
            assert tang * rotation * tau > 0, (sector, phi, tau, v.name)
            if phi:
                assert radial * phi > 0, (sector, phi, tau, v.name)
            else:
                assert abs(radial) <= 0.5 * v.magnitude + 1e-12
        radial, _ = st.components(v, st.sector_center(sector))
        if phi == 0:
            assert radial == pytest.approx(0.0, abs=1e-12)


def test_cw_table_is_mirror_of_ccw():
    ccw, cw = st.derive_flux_table(SIX, 1), st.derive_flux_table(SIX, -1)
    for (sector, phi, tau), v in ccw.items():
        assert cw[(sector, phi, -tau)] is not None
        assert cw[(sector, phi, -tau)].name == v.name


@pytest.mark.parametrize('vectors', [SIX, FOUR], ids=['six', 'four'])
@pytest.mark.parametrize('rotation', [1, -1])
def test_phi0_entries_move_torque_as_commanded(vectors, rotation):
    """dT/dt = 3/2 p (k . di/dt) with di/dt = (v - e)/L: sign = rotation * tau for every rotor angle
    of the sector, trapezoidal back-EMF, at standstill and at a speed below base speed."""
    tab = make_table('trapezoid')
    t = st.derive_flux_table(vectors, rotation)
    v_dc = 56.57
    for sector in st.SECTORS:
        for tau in (1, -1):
            v = t[(sector, 0, tau)]
            for rel in SECTOR_ANGLES:
                th = st.sector_center(sector) + rel
                k = tab.k_abc(th)
                for omega_e in (0.0, rotation * 60.0):
                    emf = tuple(omega_e * kx for kx in k)
                    ph = vx.phase_voltages(v.legs, v_dc, None, emf)
                    didt = [ph[x] - emf[x] if v.legs[x] != vx.OPEN else 0.0 for x in range(3)]
                    dT = sum(kx * d for kx, d in zip(k, didt))
                    assert dT * rotation * tau > 0, (sector, tau, v.name, math.degrees(th))


def test_split_sectors_are_ii_and_v_and_table_v_derivation():
    t = st.derive_flux_table(FOUR, 1)
    assert st.split_phase_sectors(t, 2) == (2, 5)
    sp = st.derive_split_phase_table(FOUR, 2, (2, 5), 1)
    got = {k: v.name for k, v in sp.items()}
    assert got == {(2, 1, 1): 'V3', (2, 1, -1): 'V7', (2, -1, 1): 'V0', (2, -1, -1): 'V6',
                   (5, 1, 1): 'V6', (5, 1, -1): 'V0', (5, -1, 1): 'V7', (5, -1, -1): 'V3'}
    cw = st.derive_split_phase_table(FOUR, 2, (2, 5), -1)
    for (s, ta, tb), v in sp.items():  # CW: logic inverted
        assert cw[(s, -ta, -tb)].name == v.name


@pytest.mark.parametrize('rotation', [1, -1])
def test_table_v_entries_move_each_phase_torque_as_commanded(rotation):
    """Phase c on the midpoint: all three phases conduct; di_x/dt = (v_xn - e_x)/L and
    dT_ex/dt = p k_x di_x/dt must have sign rotation * tau_x for x = a, b."""
    tab = make_table('trapezoid')
    sp = st.derive_split_phase_table(FOUR, 2, (2, 5), rotation)
    v_dc = 113.14
    for (sector, ta, tb), v in sp.items():
        for rel in SECTOR_ANGLES:
            th = st.sector_center(sector) + rel
            k = tab.k_abc(th)
            for omega_e in (0.0, rotation * 60.0):
                emf = tuple(omega_e * kx for kx in k)
                ph = vx.phase_voltages(v.legs, v_dc, 0.5 * v_dc, emf)
                for x, tau in ((0, ta), (1, tb)):
                    assert k[x] * (ph[x] - emf[x]) * rotation * tau > 0, (sector, ta, tb, v.name, x)


def test_sector_of_angle():
    assert st.sector_of_angle(0.0) == 1
    assert st.sector_of_angle(math.radians(29.9)) == 1
    assert st.sector_of_angle(math.radians(30.1)) == 2
    assert st.sector_of_angle(math.radians(-29.0)) == 1
    assert st.sector_of_angle(math.radians(271.0)) == 6
