"""drive_common.signals against analytic signals: frames, angle wrap, whole periods, harmonics, THD, PF."""
import math

import numpy as np
import pytest

from drive_common import signals

FS = 48000.0        # 800 samples per 60 Hz cycle
F = 60.0
SPP = FS / F
T = np.arange(int(SPP) * 5) / FS      # 5 whole cycles
W = 2 * math.pi * F


def test_clarke_of_balanced_set_has_phase_amplitude():
    for th in (0.0, 0.4, 2.0, 5.5):
        a, b, c = (math.cos(th - s) for s in signals.PHASE_SHIFT)
        al, be = signals.clarke(a, b, c)
        assert al == pytest.approx(math.cos(th)) and be == pytest.approx(math.sin(th))
        assert signals.inverse_clarke(al, be) == pytest.approx((a, b, c))
    rows = np.array([[math.cos(th - s) for s in signals.PHASE_SHIFT] for th in (0.1, 0.2)])
    al, be = signals.clarke_rows(rows)
    np.testing.assert_allclose(al, np.cos([0.1, 0.2]))
    np.testing.assert_allclose(be, np.sin([0.1, 0.2]))


def test_power_identity_three_halves():
    e = (1.0, -0.3, -0.7)
    i = (2.0, 0.5, -2.5)
    ea, eb = signals.clarke(*e)
    ia, ib = signals.clarke(*i)
    assert sum(x * y for x, y in zip(e, i)) == pytest.approx(1.5 * (ea * ia + eb * ib))


def test_park_roundtrip_alignment_and_arrays():
    d, q = signals.park(math.cos(0.7), math.sin(0.7), 0.7)
    assert (d, q) == pytest.approx((1.0, 0.0), abs=1e-12)
    assert signals.inverse_park(*signals.park(0.3, -1.2, 2.1), 2.1) == pytest.approx((0.3, -1.2))
    th = np.array([0.3, 1.9])
    d, q = signals.park(np.cos(th), np.sin(th), th)
    np.testing.assert_allclose(d, 1.0)
    np.testing.assert_allclose(q, 0.0, atol=1e-12)


def test_wrap_angle_and_wrap_to_pi():
    assert signals.wrap_angle(-0.1) == pytest.approx(2 * math.pi - 0.1)
    assert signals.wrap_angle(7.0) == pytest.approx(7.0 - 2 * math.pi)
    assert 0.0 <= signals.wrap_angle(-1e-300) < 2 * math.pi
    np.testing.assert_allclose(signals.wrap_to_pi([3.5, -3.5, 0.2]), [3.5 - 2 * math.pi, 2 * math.pi - 3.5, 0.2])


def test_pure_sine_spectrum():
    i = 2.0 * np.sin(W * T)
    h = signals.harmonics(i, 5, 40)
    assert abs(h[1]) == pytest.approx(2.0)
    assert signals.thd(i, 5, 40) == pytest.approx(0.0, abs=1e-12)
    assert signals.rms(i) == pytest.approx(2.0 / math.sqrt(2))
    assert signals.power_factor(np.sin(W * T), i) == pytest.approx(1.0, abs=1e-12)


def test_total_thd_of_three_phases_eq39():
    assert signals.total_thd([3.0, 4.0, 5.0]) == pytest.approx(math.sqrt((9 + 16 + 25) / 3))
    assert signals.thd_of([0.5, 2.0, 0.0, 0.2]) == pytest.approx(0.1)
    with pytest.raises(ValueError, match='no fundamental'):
        signals.thd_of([1.0, 0.0, 0.3])


def test_known_harmonic_mix():
    v = np.sin(W * T)
    i = np.sin(W * T) + 0.2 * np.sin(3 * W * T + 0.4) + 0.1 * np.sin(5 * W * T) + 0.05 * np.cos(39 * W * T)
    expected = math.sqrt(0.2 ** 2 + 0.1 ** 2 + 0.05 ** 2)
    assert signals.thd(i, 5, 40) == pytest.approx(expected, rel=1e-9)
    assert signals.power_factor(v, i) == pytest.approx(1 / math.sqrt(1 + expected ** 2), rel=1e-9)
    # The 41st harmonic lies beyond H = 40 and is not counted.
    assert signals.thd(i + 0.3 * np.sin(41 * W * T), 5, 40) == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize('phi', [0.3, -0.7, math.pi / 3])
def test_phase_shifted_sine(phi):
    v = np.sin(W * T)
    i = np.sin(W * T - phi)
    assert signals.power_factor(v, i) == pytest.approx(math.cos(phi), abs=1e-9)
    assert signals.displacement_factor(v, i, 5) == pytest.approx(math.cos(phi), abs=1e-9)


def test_rectifier_pulse_current_matches_fourier_series():
    """Pulses of width w centred on the voltage peaks, alternating sign (capacitor-input rectifier).

    Odd harmonics b_h = (4/(h pi)) sin(h w / 2); THD over h = 3..39.
    """
    n = 3600                                  # samples per cycle: 1 deg each
    t = np.arange(n * 4) / (n * F)
    deg = np.arange(n * 4) % n * (360.0 / n)
    width = 60.0                              # deg
    i = np.where(np.abs(deg - 90.0) < width / 2, 1.0, 0.0) - np.where(np.abs(deg - 270.0) < width / 2, 1.0, 0.0)
    w = math.radians(width)
    b = {h: abs(math.sin(h * w / 2) / h) for h in range(1, 40, 2)}
    expected = math.sqrt(sum(b[h] ** 2 for h in range(3, 40, 2))) / b[1]
    # Sampled pulses (odd sample counts of 1 deg) carry a small discretisation error.
    assert signals.thd(i, 4, 40) == pytest.approx(expected, rel=5e-3)
    v = np.sin(2 * math.pi * F * t)
    expected_pf = (2 * math.sqrt(2) / math.pi) * math.sin(w / 2) / math.sqrt(w / math.pi)
    assert signals.power_factor(v, i) == pytest.approx(expected_pf, rel=5e-3)
    assert expected > 0.5


def test_whole_periods_of_non_integer_records():
    # 1333.3 samples per cycle: 3 cycles are the shortest with an integer sample count
    assert signals.samples_per_whole_periods(10000, 80000.0 / 60.0) == (8000, 6)
    assert signals.samples_per_whole_periods(10000, 80000.0 / 60.0, max_periods=5) == (4000, 3)
    assert signals.periods_in(8000, 80000.0 / 60.0) == 6
    # Exactly 6 cycles whose period, from a measured step, is a hair too long: still 6, not 3.
    measured = 1.0 / float(np.median(np.diff(np.arange(8001) * 1.25e-5))) / 60.0
    assert measured > 80000.0 / 60.0
    assert signals.samples_per_whole_periods(8000, measured) == (8000, 6)
    assert signals.samples_per_whole_periods(7999, measured) == (4000, 3)
    with pytest.raises(ValueError, match='whole number'):
        signals.periods_in(1333, 80000.0 / 60.0)
    with pytest.raises(ValueError, match='no whole number'):
        signals.samples_per_whole_periods(1000, 80000.0 / 60.0)
