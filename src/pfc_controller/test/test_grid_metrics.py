"""grid_metrics against analytic signals."""
import math

import numpy as np
import pytest

from pfc_controller.grid_metrics import (analyze, cycles_in, dc_ripple, harmonics, power_factor,
                                         rms, thd, whole_cycles)

FS = 48000.0        # 800 samples per 60 Hz cycle
F = 60.0
T = np.arange(int(FS / F) * 5) / FS      # 5 whole cycles
W = 2 * math.pi * F


def test_pure_sine():
    v = 35.9 * np.sin(W * T)
    i = 2.0 * np.sin(W * T)
    m = analyze(v, i, FS, F)
    assert m.power_factor == pytest.approx(1.0, abs=1e-12)
    assert m.displacement_factor == pytest.approx(1.0, abs=1e-12)
    assert m.current_thd == pytest.approx(0.0, abs=1e-12)
    assert m.current_rms == pytest.approx(2.0 / math.sqrt(2))
    assert m.real_power == pytest.approx(35.9 * 2.0 / 2)
    assert m.current_harmonics[1] == pytest.approx(2.0)


def test_known_harmonic_mix():
    v = np.sin(W * T)
    i = np.sin(W * T) + 0.2 * np.sin(3 * W * T + 0.4) + 0.1 * np.sin(5 * W * T) + 0.05 * np.cos(39 * W * T)
    expected = math.sqrt(0.2 ** 2 + 0.1 ** 2 + 0.05 ** 2)
    assert thd(i, FS, F) == pytest.approx(expected, rel=1e-9)
    assert power_factor(v, i) == pytest.approx(1 / math.sqrt(1 + expected ** 2), rel=1e-9)
    # The 41st harmonic lies beyond H = 40 and is not counted.
    assert thd(i + 0.3 * np.sin(41 * W * T), FS, F) == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize('phi', [0.3, -0.7, math.pi / 3])
def test_phase_shifted_sine(phi):
    v = np.sin(W * T)
    i = np.sin(W * T - phi)
    m = analyze(v, i, FS, F)
    assert m.power_factor == pytest.approx(math.cos(phi), abs=1e-9)
    assert m.displacement_factor == pytest.approx(math.cos(phi), abs=1e-9)


def test_rectifier_pulse_current_matches_fourier_series():
    """Pulses of width w centred on the voltage peaks, alternating sign (capacitor-input rectifier).

    Odd harmonics b_h = (4/(h pi)) sin(h w / 2); THD over h = 3..39.
    """
    n = 3600                                  # samples per cycle: 1 deg each
    fs = n * F
    t = np.arange(n * 4) / fs
    deg = np.arange(n * 4) % n * (360.0 / n)
    width = 60.0                              # deg
    i = np.where(np.abs(deg - 90.0) < width / 2, 1.0, 0.0) - np.where(np.abs(deg - 270.0) < width / 2, 1.0, 0.0)
    w = math.radians(width)
    b = {h: abs(math.sin(h * w / 2) / h) for h in range(1, 40, 2)}
    expected = math.sqrt(sum(b[h] ** 2 for h in range(3, 40, 2))) / b[1]
    # Sampled pulses (odd sample counts of 1 deg) carry a small discretisation error.
    assert thd(i, fs, F) == pytest.approx(expected, rel=5e-3)
    v = np.sin(2 * math.pi * F * t)
    expected_pf = (2 * math.sqrt(2) / math.pi) * math.sin(w / 2) / math.sqrt(w / math.pi)
    assert power_factor(v, i) == pytest.approx(expected_pf, rel=5e-3)
    assert expected > 0.5


def test_rms_and_dc_ripple():
    assert rms(np.full(10, -3.0)) == pytest.approx(3.0)
    r = dc_ripple(80.0 + 5.0 * np.sin(2 * W * T))
    assert r.mean == pytest.approx(80.0)
    assert r.peak_to_peak == pytest.approx(10.0, rel=1e-4)
    assert r.percent == pytest.approx(12.5, rel=1e-4)


def test_whole_cycles_and_non_integer_records():
    x = np.sin(2 * math.pi * 60 * np.arange(10000) / 80000.0)   # 1333.3 samples per cycle
    y = whole_cycles(x, 80000.0, 60.0)
    assert len(y) == 8000 and cycles_in(len(y), 80000.0, 60.0) == 6
    with pytest.raises(ValueError, match='whole number'):
        harmonics(x[:1333], 80000.0, 60.0)
