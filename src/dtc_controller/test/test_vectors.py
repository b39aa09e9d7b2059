"""Every vector's alpha/beta voltage equals the circuit's (independent nodal solution)."""
import itertools
import math

import numpy as np
import pytest

from dtc_controller.core import vectors as vx
from drive_common import signals

VDC = 113.137  # 80 sqrt(2) V


def circuit_phase_voltages(switch_on, v_dc, v_mid, midpoint_phase, emf):
    """Independent nodal analysis of inverter + Y motor (equal R per phase, zero current initially
    is irrelevant: solve the resistive network with EMF sources), open phases carry no current."""
    terminals = []
    for x in range(3):
        if x == midpoint_phase:
            terminals.append(v_mid)
        elif switch_on[2 * x]:
            terminals.append(v_dc)
        elif switch_on[2 * x + 1]:
            terminals.append(0.0)
        else:
            terminals.append(None)
    cond = [x for x in range(3) if terminals[x] is not None]
    # unknowns: neutral voltage v_n and conducting currents i_x (R = 1):  v_x = v_n + i_x + e_x, sum i = 0
    n = len(cond)
    a = np.zeros((n + 1, n + 1))
    b = np.zeros(n + 1)
    for row, x in enumerate(cond):
        a[row, 0] = 1.0
        a[row, 1 + row] = 1.0
        b[row] = terminals[x] - emf[x]
    a[n, 1:] = 1.0
    v_n = np.linalg.solve(a, b)[0]
    return [terminals[x] - v_n if terminals[x] is not None else emf[x] for x in range(3)]


def clarke(v):
    return (2 * v[0] - v[1] - v[2]) / 3, (v[1] - v[2]) / math.sqrt(3)


ALL = [(vx.two_phase_six_switch_vectors(), None), (vx.four_switch_vectors(2), 2), (vx.four_switch_vectors(0), 0),
       (vx.three_phase_six_switch_vectors(), None)]


@pytest.mark.parametrize('vectors, mid', ALL)
@pytest.mark.parametrize('emf', [(0.0, 0.0, 0.0), (3.0, -5.0, 2.0)])
def test_vector_equals_circuit(vectors, mid, emf):
    for v in vectors:
        if sum(1 for leg in v.legs if leg != vx.OPEN) < 2:
            continue
        want = clarke(circuit_phase_voltages(v.switch_on, VDC, 0.47 * VDC, mid, emf))
        assert v.voltage(VDC, 0.47 * VDC, emf) == pytest.approx(want, abs=1e-9), v.name
        if emf == (0.0, 0.0, 0.0):
            ideal = clarke(circuit_phase_voltages(v.switch_on, VDC, 0.5 * VDC, mid, emf))
            assert (v.alpha * VDC, v.beta * VDC) == pytest.approx(ideal, abs=1e-9), v.name
        # linear coefficient model used per sample
        a_dc, a_mid, b_dc, b_mid, terms = vx.voltage_coefficients(v.legs)
        va = a_dc * VDC + a_mid * 0.47 * VDC + sum(ka * emf[x] for x, ka, _ in terms)
        vb = b_dc * VDC + b_mid * 0.47 * VDC + sum(kb * emf[x] for x, _, kb in terms)
        assert (va, vb) == pytest.approx(want, abs=1e-9)


def test_six_switch_two_phase_geometry_fixes_appendix_c():
    """V_k at 30 + 60 (k-1) deg, |V| = V_dc/sqrt(3) (Appendix C scaled by 1/sqrt(3); its V2beta typo fixed)."""
    vs = vx.by_name(vx.two_phase_six_switch_vectors())
    codes = {'V1': '100001', 'V2': '001001', 'V3': '011000', 'V4': '010010', 'V5': '000110', 'V6': '100100'}
    for k in range(1, 7):
        v = vs[f'V{k}']
        assert v.code() == codes[v.name]  # Table II codes
        assert math.degrees(v.angle) == pytest.approx(30 + 60 * (k - 1))
        assert v.magnitude == pytest.approx(1 / math.sqrt(3))
        assert v.two_phase


def test_four_switch_geometry_and_naming():
    vs = vx.by_name(vx.four_switch_vectors(2))
    codes = {'V1': '1000', 'V2': '0010', 'V3': '0110', 'V4': '0100', 'V5': '0001', 'V6': '1001',
             'V0': '1010', 'V7': '0101'}  # Table IV/V and Fig. 4.5 codes
    for name, code in codes.items():
        assert vs[name].code(4) == code
    for k in range(1, 7):
        assert math.degrees(vs[f'V{k}'].angle) == pytest.approx(30 + 60 * (k - 1))
    # half-DC-link vectors through the midpoint, full ones between a and b
    assert [round(vs[f'V{k}'].magnitude * math.sqrt(3), 6) for k in range(1, 7)] == [0.5, 0.5, 1, 0.5, 0.5, 1]
    assert math.degrees(vs['V0'].angle) == pytest.approx(60) and vs['V0'].magnitude == pytest.approx(1 / 3)
    assert math.degrees(vs['V7'].angle) == pytest.approx(240)
    assert not vs['V0'].two_phase and not vs['V7'].two_phase


def test_three_phase_table_i_numbering():
    vs = vx.by_name(vx.three_phase_six_switch_vectors())
    sa_sb_sc = {n: ''.join('1' if v.switch_on[2 * x] else '0' for x in range(3)) for n, v in vs.items()}
    assert sa_sb_sc == {'V1': '100', 'V2': '110', 'V3': '010', 'V4': '011', 'V5': '001', 'V6': '101',
                        'V0': '000', 'V7': '111'}
    assert all(v.magnitude == pytest.approx(2 / 3) for n, v in vs.items() if n not in ('V0', 'V7'))


def test_shoot_through_rejected():
    with pytest.raises(ValueError, match='shoot-through'):
        vx.leg_states((True, True, False, False, False, False))


def test_every_switch_state_matches_circuit():
    """Not only the tabulated vectors: every legal 6-switch state, with a midpoint or not."""
    for bits in itertools.product((False, True), repeat=6):
        if any(bits[2 * x] and bits[2 * x + 1] for x in range(3)):
            continue
        for mid in (None, 0, 1, 2):
            legs = vx.leg_states(bits, mid)
            if sum(1 for leg in legs if leg != vx.OPEN) < 2:
                continue
            emf = (1.0, 2.0, -3.0)
            got = signals.clarke(*vx.phase_voltages(legs, VDC, 0.4 * VDC, emf))
            assert got == pytest.approx(clarke(circuit_phase_voltages(bits, VDC, 0.4 * VDC, mid, emf)))
