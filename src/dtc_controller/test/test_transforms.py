import math

import pytest

from dtc_controller.core import transforms as tf


def test_clarke_of_balanced_set_has_phase_amplitude():
    for th in (0.0, 0.4, 2.0, 5.5):
        a, b, c = (math.cos(th - s) for s in tf.PHASE_SHIFT)
        al, be = tf.clarke(a, b, c)
        assert al == pytest.approx(math.cos(th)) and be == pytest.approx(math.sin(th))
        assert tf.inverse_clarke(al, be) == pytest.approx((a, b, c))
        assert tf.clarke_balanced(a, b) == pytest.approx((al, be))


def test_power_identity_three_halves():
    e = (1.0, -0.3, -0.7)
    i = (2.0, 0.5, -2.5)
    ea, eb = tf.clarke(*e)
    ia, ib = tf.clarke(*i)
    assert sum(x * y for x, y in zip(e, i)) == pytest.approx(1.5 * (ea * ia + eb * ib))


def test_park_roundtrip_and_alignment():
    d, q = tf.park(math.cos(0.7), math.sin(0.7), 0.7)
    assert (d, q) == pytest.approx((1.0, 0.0), abs=1e-12)
    assert tf.inverse_park(*tf.park(0.3, -1.2, 2.1), 2.1) == pytest.approx((0.3, -1.2))


def test_line_to_line_recovers_alpha_beta():
    a, b, c = 0.4, 0.5, -0.9
    assert tf.alpha_beta_from_line_to_line(*tf.line_to_line_constants(a, b, c)) == pytest.approx(tf.clarke(a, b, c))


def test_reconstruct_missing_current():
    nan = float('nan')
    assert tf.reconstruct_currents(1.0, nan, -3.0) == (1.0, 2.0, -3.0)
    assert tf.reconstruct_currents(nan, 1.0, 2.0) == (-3.0, 1.0, 2.0)
    assert tf.reconstruct_currents(1.0, 2.0, nan) == (1.0, 2.0, -3.0)
    with pytest.raises(ValueError):
        tf.reconstruct_currents(nan, nan, 1.0)


def test_wrap_angle():
    assert tf.wrap_angle(-0.1) == pytest.approx(2 * math.pi - 0.1)
    assert tf.wrap_angle(7.0) == pytest.approx(7.0 - 2 * math.pi)
    assert 0.0 <= tf.wrap_angle(-1e-300) < 2 * math.pi
