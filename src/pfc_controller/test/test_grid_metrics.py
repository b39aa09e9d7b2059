"""grid_metrics against analytic signals (the spectrum itself: drive_common/test/test_signals.py)."""
import math

import numpy as np
import pytest

from pfc_controller.grid_metrics import analyze, dc_ripple, whole_cycles

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


@pytest.mark.parametrize('phi', [0.3, -0.7, math.pi / 3])
def test_phase_shifted_sine(phi):
    v = np.sin(W * T)
    i = np.sin(W * T - phi)
    m = analyze(v, i, FS, F)
    assert m.power_factor == pytest.approx(math.cos(phi), abs=1e-9)
    assert m.displacement_factor == pytest.approx(math.cos(phi), abs=1e-9)


def test_dc_ripple():
    r = dc_ripple(80.0 + 5.0 * np.sin(2 * W * T))
    assert r.mean == pytest.approx(80.0)
    assert r.peak_to_peak == pytest.approx(10.0, rel=1e-4)
    assert r.percent == pytest.approx(12.5, rel=1e-4)


def test_whole_cycles_and_non_integer_records():
    x = np.sin(2 * math.pi * 60 * np.arange(10000) / 80000.0)   # 1333.3 samples per cycle
    y = whole_cycles(x, 80000.0, 60.0)
    assert len(y) == 8000 and analyze(y, y, 80000.0, 60.0).power_factor == pytest.approx(1.0)
    with pytest.raises(ValueError, match='whole number'):
        analyze(x[:1333], x[:1333], 80000.0, 60.0)
