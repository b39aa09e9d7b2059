"""Inverter voltage-drop compensation (001 Tables III-VI, eqs. 26-38) against the device model."""
import math
import random

import pytest

from dtc_controller.core import voltage_drop_compensation as vdc
from dtc_controller.core.three_phase_tables import fstp_vectors
from drive_common.signals import clarke
from dtc_controller.core.vectors import three_phase_six_switch_vectors, voltage_coefficients

SQ3 = math.sqrt(3.0)


def correction(scheme, mid, switch_on, cur, v_ce=0.9, v_d=1.25, v_f=0.9, r_on=0.075):
    """(dv_alpha, dv_beta) [V] the three-phase kernel adds for a switch state and leg currents [A]."""
    return vdc.correction(vdc.SCHEMES.index(scheme), -1 if mid is None else mid, *switch_on[0::2], *cur,
                          v_ce, v_d, v_f, r_on)


def test_table_iii_conduction_paths():
    """Terminal voltage per conducting device: upper IGBT, upper diode, lower diode, lower IGBT (+ R_on i)."""
    vdc_, vce, vd, ron = 70.0, 0.9, 1.25, 0.075
    assert vdc.leg_terminal_voltage(True, 2.0, vdc_, vce, vd, ron) == pytest.approx(vdc_ - vce - ron * 2.0)
    assert vdc.leg_terminal_voltage(True, -2.0, vdc_, vce, vd, ron) == pytest.approx(vdc_ + vd + ron * 2.0)
    assert vdc.leg_terminal_voltage(False, 2.0, vdc_, vce, vd, ron) == pytest.approx(-vd - ron * 2.0)
    assert vdc.leg_terminal_voltage(False, -2.0, vdc_, vce, vd, ron) == pytest.approx(vce + ron * 2.0)


def test_printed_table_v():
    vf = 0.9
    printed = {(-1, -1): (-2 * vf / 3, 0.0), (-1, 1): (0.0, 2 * vf / SQ3),
               (1, -1): (0.0, -2 * vf / SQ3), (1, 1): (2 * vf / 3, 0.0)}
    got = {(sb, sc): correction('simple', 0, (False,) * 6, (0.0, float(sb), float(sc)), v_f=vf)
           for sb in (-1, 1) for sc in (-1, 1)}
    for key, want in printed.items():
        assert got[key] == pytest.approx(want, abs=1e-12)


@pytest.mark.parametrize('vce,vd', [(0.9, 1.25), (0.7, 1.6)])
def test_printed_table_vi(vce, vd):
    """001 Table VI, all 16 rows as printed (S_B, S_C, sign i_b, sign i_c) -> (v_falpha, v_fbeta)."""
    P = {
        (0, 0, -1, -1): (-2 * vce / 3, 0), (0, 1, -1, -1): (-(vd + vce) / 3, -(vd - vce) / SQ3),
        (1, 0, -1, -1): (-(vd + vce) / 3, (vd - vce) / SQ3), (1, 1, -1, -1): (-2 * vd / 3, 0),
        (0, 0, -1, 1): ((vd - vce) / 3, (vd + vce) / SQ3), (0, 1, -1, 1): (0, 2 * vce / SQ3),
        (1, 0, -1, 1): (0, 2 * vd / SQ3), (1, 1, -1, 1): (-(vd - vce) / 3, (vd + vce) / SQ3),
        (0, 0, 1, -1): ((vd - vce) / 3, -(vd + vce) / SQ3), (0, 1, 1, -1): (0, -2 * vd / SQ3),
        (1, 0, 1, -1): (0, -2 * vce / SQ3), (1, 1, 1, -1): (-(vd - vce) / 3, -(vd + vce) / SQ3),
        (0, 0, 1, 1): (2 * vd / 3, 0), (0, 1, 1, 1): ((vd + vce) / 3, -(vd - vce) / SQ3),
        (1, 0, 1, 1): ((vd + vce) / 3, (vd - vce) / SQ3), (1, 1, 1, 1): (2 * vce / 3, 0),
    }
    got = {}
    for s_b, s_c, sb, sc in P:
        sw = (False, False, bool(s_b), not s_b, bool(s_c), not s_c)
        got[(s_b, s_c, sb, sc)] = correction('proposed', 0, sw, (0.0, float(sb), float(sc)), vce, vd, r_on=0.0)
    assert set(got) == set(P)
    for key, want in P.items():
        assert got[key] == pytest.approx(want, abs=1e-12), key


@pytest.mark.parametrize('topology', ['fstp', 'sstp'])
def test_proposed_compensation_reproduces_device_model(topology):
    """ideal vector + correction == Clarke of the terminal voltages the device model gives, any state/current."""
    rng = random.Random(7)
    if topology == 'fstp':
        vectors, mid = fstp_vectors(0), 0
    else:
        vectors, mid = [v for v in three_phase_six_switch_vectors()], None
    for _ in range(200):
        v_dc, v_mid = rng.uniform(40, 80), 0.0
        v_mid = v_dc * rng.uniform(0.45, 0.55)
        vce, vd, ron = rng.uniform(0.5, 1.5), rng.uniform(0.5, 2.0), rng.uniform(0.0, 0.3)
        ia, ib = rng.uniform(-4, 4), rng.uniform(-4, 4)
        cur = (ia, ib, -ia - ib)
        v = rng.choice(vectors)
        terms = []
        for x in range(3):
            if x == mid:
                terms.append(v_mid)
            else:
                terms.append(vdc.leg_terminal_voltage(v.switch_on[2 * x], cur[x], v_dc, vce, vd, ron))
        want = clarke(*terms)
        a_dc, a_mid, b_dc, b_mid, _ = voltage_coefficients(v.legs)
        ideal = (a_dc * v_dc + a_mid * v_mid, b_dc * v_dc + b_mid * v_mid)
        d = correction('proposed', mid, v.switch_on, cur, vce, vd, 0.0, ron)
        assert (ideal[0] + d[0], ideal[1] + d[1]) == pytest.approx(want, abs=1e-9)


def test_r_on_terms_sign_of_eqs_37_38():
    """With V_CE = V_d = 0 the FSTP correction is (-R_on i_alpha/3, -R_on i_beta): eq. (37)'s '+' is a typo."""
    ia, ib = 1.7, -0.4
    cur = (ia, ib, -ia - ib)
    i_al, i_be = clarke(*cur)
    for v in fstp_vectors(0):
        assert correction('proposed', 0, v.switch_on, cur, 0.0, 0.0) == pytest.approx(
            (-0.075 * i_al / 3, -0.075 * i_be), abs=1e-12)
    v = three_phase_six_switch_vectors()[0]
    assert correction('proposed', None, v.switch_on, cur, 0.0, 0.0) == pytest.approx((-0.075 * i_al, -0.075 * i_be), abs=1e-12)


def test_simple_equals_proposed_for_equal_drops_and_none_is_zero():
    rng = random.Random(9)
    for _ in range(50):
        ia, ib = rng.uniform(-4, 4), rng.uniform(-4, 4)
        cur = (ia, ib, -ia - ib)
        sw = rng.choice(fstp_vectors(0)).switch_on
        assert correction('simple', 0, sw, cur, v_f=1.1) == pytest.approx(
            correction('proposed', 0, sw, cur, 1.1, 1.1, r_on=0.0))
        assert correction('none', 0, sw, cur) == (0.0, 0.0)
