"""Line-to-line Clarke (5.10), Park (5.15), torque (5.32)/(5.33) and the DTIFC rotor-flux amplitude."""
import math
import random

import numpy as np
import pytest

from dtc_controller.core import line_to_line as ll
from dtc_controller.core.backemf_table import BackEmfTable
from drive_common.signals import clarke, park

SHIFT = (0.0, 2 * math.pi / 3, 4 * math.pi / 3)


def trapezoid(theta):
    """Ideal 120-deg flat-top unit trapezoid with fundamental -sin(theta) (docs/architecture.md)."""
    d = np.degrees(np.mod(theta, 2 * np.pi))
    return np.interp(d, [0, 30, 150, 210, 330, 360], [0, -1, -1, 1, 1, 0])


def table_of(shape, k, pole_pairs=2, points=252):
    th = np.arange(points) * 2 * np.pi / points
    return BackEmfTable.from_phase_constants(*[k * shape(th - s) for s in SHIFT], pole_pairs)


def harmonic(theta):
    return -(np.sin(theta) + 0.2 * np.sin(3 * theta) + 0.05 * np.sin(5 * theta))


def _zero_sum(rng):
    a, b = rng.uniform(-10, 10), rng.uniform(-10, 10)
    return a, b, -a - b


def test_line_to_line_clarke_and_inverse():
    rng = random.Random(1)
    for _ in range(100):
        xa, xb, xc = _zero_sum(rng)
        ba, ca = xb - xa, xc - xa
        assert ll.line_to_line_clarke(ba, ca) == pytest.approx(clarke(xa, xb, xc), abs=1e-12)
        assert ll.line_to_line_inverse(ba, ca) == pytest.approx((xa, xb, xc), abs=1e-12)


def test_line_to_line_park_equals_clarke_park_and_seed_q_sign():
    rng = random.Random(2)
    for _ in range(200):
        xa, xb, xc = _zero_sum(rng)
        th = rng.uniform(-10, 10)
        want = park(*clarke(xa, xb, xc), th)
        got = ll.line_to_line_park(xb - xa, xc - xa, th)
        assert got == pytest.approx(want, abs=1e-12)
        # as printed, (5.15) has q lagging d (eq. 5.4): q_seed = -q
        d_s, q_s = ll.line_to_line_park_seed(xb - xa, xc - xa, th)
        assert (d_s, q_s) == pytest.approx((want[0], -want[1]), abs=1e-12)
        # the seed's q row literally: 2/3 [-cos(th - pi/6) x_ba + cos(th + pi/6) x_ca]
        lit = 2 / 3 * (-math.cos(th - math.pi / 6) * (xb - xa) + math.cos(th + math.pi / 6) * (xc - xa))
        assert q_s == pytest.approx(lit, abs=1e-12)


@pytest.mark.parametrize('shape', [trapezoid, harmonic, lambda t: -np.sin(t)])
def test_torque_5_32_equals_phase_torque_and_5_33(shape):
    """T = p sum k_x i_x (phase variables) = (5.32) with table k_d/k_q = (5.33), random currents and angles."""
    p, k = 2, 0.0573
    tab = table_of(shape, k, p, points=3600)
    dq = ll.DqBackEmf(tab)
    rng = random.Random(3)
    for _ in range(200):
        th = rng.uniform(0, 2 * math.pi)
        ia, ib, ic = _zero_sum(rng)
        ka, kb, kc = tab.k_abc(th)
        t_phase = p * (ka * ia + kb * ib + kc * ic)
        i_d, i_q = ll.line_to_line_park(ib - ia, ic - ia, th)
        k_d, k_q = dq.k_dq(th)
        t_532 = ll.torque_dq(p, k_d, k_q, i_d, i_q)
        t_533 = ll.torque_line_to_line(p, kb - ka, kc - ka, ib - ia, ic - ia)
        assert t_533 == pytest.approx(t_phase, rel=1e-9, abs=1e-12)
        # k_d/k_q columns are interpolated separately: small interpolation error only
        assert t_532 == pytest.approx(t_phase, abs=2e-3 * k * p * 20)


def test_trapezoid_rotor_flux_reconciled_with_seed():
    """000 (E.9)/(5.37): 2 pi k_LL/(3 sqrt 3) is the swing; the amplitude-invariant amplitude is 7 pi k_LL/36."""
    k_ll = 0.1146                       # line-to-line peak [V s/rad]; flat top = k_LL / 2
    tab = table_of(trapezoid, k_ll / 2, points=3600)
    dq = ll.DqBackEmf(tab)
    fig = ll.trapezoid_rotor_flux(k_ll)
    assert dq.rotor_flux(0.0)[0] == pytest.approx(fig['at_phase_axis'], rel=1e-4)
    assert dq.rotor_flux(0.0)[1] == pytest.approx(0.0, abs=1e-4 * k_ll)
    assert dq.rotor_flux_max == pytest.approx(fig['at_phase_axis'], rel=1e-4)
    assert dq.rotor_flux_min == pytest.approx(fig['minimum'], rel=1e-4)
    assert fig['seed_e9'] == pytest.approx(2 * fig['minimum'])
    # seed's e_alpha' = e_ab/sqrt(3) integrated over its positive half period = the seed's number
    th = np.linspace(0, 2 * np.pi, 36001)
    e_ab = k_ll / 2 * (trapezoid(th) - trapezoid(th - SHIFT[1]))
    e_al = e_ab / math.sqrt(3)
    swing = np.trapezoid(np.clip(e_al, 0, None), th)
    assert swing == pytest.approx(fig['seed_e9'], rel=1e-4)
