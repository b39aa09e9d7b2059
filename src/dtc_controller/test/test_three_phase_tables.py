"""Three-phase switching tables and vectors derived from the circuit (000 Tables I/VI, 001 Tables I/II)."""
import math

import pytest

from dtc_controller.core import three_phase_tables as tpt
from drive_common.signals import clarke
from dtc_controller.core.vectors import three_phase_six_switch_vectors

SQ3 = math.sqrt(3.0)


def _nodal_phase_voltages(terminals):
    """Y-connected balanced load: v_xn = v_x0 - v_n0, v_n0 = mean of the terminal voltages (001 eqs. 1-3)."""
    v_n = sum(terminals) / 3.0
    return tuple(t - v_n for t in terminals)


def test_six_switch_vectors_equal_eq_1_15():
    """000 eq. (1.15): v_a = V_dc (2 S_a - S_b - S_c)/3 ...; the vector's alpha/beta is its Clarke transform."""
    v_dc = 48.0
    for v in three_phase_six_switch_vectors():
        sa, sb, sc = (1 if v.switch_on[2 * x] else 0 for x in range(3))
        va = v_dc * (2 * sa - sb - sc) / 3.0
        vb = v_dc * (-sa + 2 * sb - sc) / 3.0
        vc = v_dc * (-sa - sb + 2 * sc) / 3.0
        al, be = clarke(va, vb, vc)
        assert v.voltage(v_dc) == pytest.approx((al, be), abs=1e-12)
        if v.index in range(1, 7):
            assert math.degrees(v.angle) == pytest.approx(60.0 * (v.index - 1), abs=1e-9)
            assert v.magnitude == pytest.approx(2.0 / 3.0)


@pytest.mark.parametrize('v_mid_frac', [0.5, 0.47, 0.55])
def test_fstp_vectors_from_circuit(v_mid_frac):
    """001 Table I / eqs. (1)-(5), (17)-(19): phase a on the capacitor midpoint, legs b, c switched."""
    v_dc = 70.0
    v_mid = v_mid_frac * v_dc
    printed = {  # 001 Table I: S_B S_C -> (v_an, v_bn, v_cn, v_alpha, v_beta) per V_dc (balanced midpoint)
        '00': (1 / 3, -1 / 6, -1 / 6, 1 / 3, 0.0),
        '10': (0.0, 1 / 2, -1 / 2, 0.0, 1 / SQ3),
        '11': (-1 / 3, 1 / 6, 1 / 6, -1 / 3, 0.0),
        '01': (0.0, -1 / 2, 1 / 2, 0.0, -1 / SQ3),
    }
    vecs = tpt.fstp_vectors(0)
    assert [tpt.fstp_code(v) for v in vecs] == ['00', '10', '11', '01']
    for v in vecs:
        assert not v.switch_on[0] and not v.switch_on[1]           # SW1/SW2 unused
        s_b, s_c = (int(ch) for ch in tpt.fstp_code(v))
        assert v.switch_on[2:] == (bool(s_b), not s_b, bool(s_c), not s_c)
        phase = _nodal_phase_voltages((v_mid, s_b * v_dc, s_c * v_dc))
        assert v.voltage(v_dc, v_mid) == pytest.approx(clarke(*phase), abs=1e-12)
        if v_mid_frac == 0.5:
            want = printed[tpt.fstp_code(v)]
            assert phase == pytest.approx(tuple(x * v_dc for x in want[:3]), abs=1e-12)
            # eqs. (17)-(19) with S_A = 1/2
            assert phase == pytest.approx((v_dc * (1 - s_b - s_c) / 3, v_dc * (4 * s_b - 2 * s_c - 1) / 6,
                                           v_dc * (4 * s_c - 2 * s_b - 1) / 6), abs=1e-12)
            assert (v.alpha, v.beta) == pytest.approx(want[3:], abs=1e-12)
            assert math.degrees(v.angle) == pytest.approx(90.0 * (v.index - 1), abs=1e-9)


def _sector_angles(sector, n_sectors):
    width = 2 * math.pi / n_sectors
    if n_sectors == 6:
        start = (sector - 1) * width - width / 2
    else:
        start = (sector - 1) * width
    return [start + width * f for f in (0.05, 0.3, 0.5, 0.7, 0.95)]


CASES = [('six', r) for r in (1, -1)] + [('four', r) for r in (1, -1)]


@pytest.mark.parametrize('kind,rotation', CASES)
def test_table_effects(kind, rotation):
    """Every entry: phi = +1 raises |psi_s|, -1 lowers it; tau = +1 turns psi_s in the commanded direction.

    Checked by applying the vector's circuit voltage for a short time to a flux anywhere inside the sector.
    """
    if kind == 'six':
        table, n, sector_of, v_dc = tpt.six_switch_table(rotation), 6, tpt.six_switch_sector, 56.57
    else:
        table, n, sector_of, v_dc = tpt.four_switch_table(rotation), 4, tpt.four_sector_of_angle, 70.0
    psi, dt = 0.1, 2e-6
    for sector in range(1, n + 1):
        for ang in _sector_angles(sector, n):
            assert sector_of(ang) == sector
            pa, pb = psi * math.cos(ang), psi * math.sin(ang)
            for phi in (1, -1):
                for tau in (1, -1):
                    v = table[(sector, phi, tau)]
                    va, vb = v.voltage(v_dc, 0.5 * v_dc)
                    na, nb = pa + va * dt, pb + vb * dt
                    d_mag = math.hypot(na, nb) - psi
                    d_ang = math.remainder(math.atan2(nb, na) - ang, 2 * math.pi)
                    assert d_mag * phi > 0, (kind, sector, math.degrees(ang), phi, tau, v.name)
                    assert d_ang * tau * rotation > 0, (kind, sector, math.degrees(ang), phi, tau, v.name)


def test_torque_rises_with_tau_plus_for_a_pmsm():
    """Surface PM machine at standstill, psi_r on the alpha axis, load angle 10 deg: T = 3p/(2L) psi_r x psi_s."""
    p, L, psi_r = 2, 1e-3, 0.1
    table = tpt.six_switch_table(1)
    for delta_deg in (5.0, 10.0, 20.0):
        d = math.radians(delta_deg)
        psi_s = (psi_r * math.cos(d), psi_r * math.sin(d))
        sector = tpt.six_switch_sector(d)

        def torque(sa, sb):
            return 1.5 * p / L * psi_r * sb   # psi_r x psi_s with psi_r = (psi_r, 0)
        t0 = torque(*psi_s)
        for phi in (1, -1):
            for tau in (1, -1):
                va, vb = table[(sector, phi, tau)].voltage(50.0)
                t1 = torque(psi_s[0] + va * 1e-6, psi_s[1] + vb * 1e-6)
                assert (t1 - t0) * tau > 0


def test_corrected_000_tables_match_derivation_and_list_typos():
    derived = tpt.six_switch_table(1)
    corrected = tpt.corrected_000_table()
    for (phi, tau), row in corrected.items():
        for sector, (idx, code) in enumerate(row, start=1):
            v = derived[(sector, phi, tau)]
            assert (v.index, v.code(6)[0::2]) == (idx, code)
    # the printed indices are right; 15 of the 24 printed codes are not
    for (phi, tau), row in tpt.PRINTED_000_TABLE_I.items():
        key = (1 if phi else -1, 1 if tau else -1)
        assert [i for i, _ in row] == [i for i, _ in corrected[key]]
    typos = tpt.printed_000_typos()
    assert len(typos) == 15
    assert any('theta(5): printed V6(110), circuit V6(101)' in t for t in typos)
    assert tpt.PRINTED_000_TABLE_VI[(1, -1)] == tpt.PRINTED_000_TABLE_I[(1, 0)]


def test_001_table_ii_matches_derivation():
    assert tpt.corrected_001_table_ii() == tpt.PRINTED_001_TABLE_II


def test_cw_tables_mirror_ccw():
    ccw, cw = tpt.six_switch_table(1), tpt.six_switch_table(-1)
    for (sector, phi, tau), v in ccw.items():
        assert cw[(sector, phi, -tau)] is v or cw[(sector, phi, -tau)].index == v.index


def test_four_sector_boundaries():
    assert tpt.four_sector_of_angle(0.0) == 1
    assert tpt.four_sector_of_angle(math.radians(89.9)) == 1
    assert tpt.four_sector_of_angle(math.radians(90.0)) == 2
    assert tpt.four_sector_of_angle(math.radians(-0.1)) == 4
    assert tpt.six_switch_sector(math.radians(-29.9)) == 1
    assert tpt.six_switch_sector(math.radians(30.1)) == 2
