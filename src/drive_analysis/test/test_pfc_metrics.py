"""The PFC line-side metrics against analytic signals (the spectrum: drive_common test_signals.py)."""
import math

import numpy as np
import pytest

from drive_analysis.metrics import pfc
from drive_common import signals

FS = 48000.0        # 800 samples per 60 Hz cycle
F = 60.0
T = np.arange(int(FS / F) * 5) / FS      # 5 whole cycles
W = 2 * math.pi * F


def _arrays(v, i=None, vo=None, sample_rate: float = FS) -> dict:
    """drive_analysis arrays (plant/state.<field>) of evenly sampled records."""
    v = np.asarray(v)
    out = {'plant/state.time': np.arange(len(v)) / sample_rate, 'plant/state.grid_voltage': v,
           'plant/state.grid_current': v if i is None else i}
    return out if vo is None else dict(out, **{'plant/state.dc_link_voltage': vo})


def test_pure_sine():
    v = 35.9 * np.sin(W * T)
    i = 2.0 * np.sin(W * T)
    a = _arrays(v, i)
    assert pfc.line_power_factor(a) == pytest.approx(1.0, abs=1e-12)
    assert pfc.line_displacement_factor(a) == pytest.approx(1.0, abs=1e-12)
    assert pfc.line_current_thd_pct(a) == pytest.approx(0.0, abs=1e-10)
    assert pfc.line_current_rms_A(a) == pytest.approx(2.0 / math.sqrt(2))
    assert pfc.line_real_power_W(a) == pytest.approx(35.9 * 2.0 / 2)
    assert abs(signals.harmonics(i, 5, 40)[1]) == pytest.approx(2.0)


@pytest.mark.parametrize('phi', [0.3, -0.7, math.pi / 3])
def test_phase_shifted_sine(phi):
    a = _arrays(np.sin(W * T), np.sin(W * T - phi))
    assert pfc.line_power_factor(a) == pytest.approx(math.cos(phi), abs=1e-9)
    assert pfc.line_displacement_factor(a) == pytest.approx(math.cos(phi), abs=1e-9)


def test_dc_ripple():
    a = _arrays(T, vo=80.0 + 5.0 * np.sin(2 * W * T))
    assert pfc.mean_output_voltage_V(a) == pytest.approx(80.0)
    assert pfc.output_voltage_ripple_pp_V(a) == pytest.approx(10.0, rel=1e-4)


def test_whole_cycles_and_non_integer_records():
    x = np.sin(2 * math.pi * 60 * np.arange(10000) / 80000.0)   # 1333.3 samples per cycle
    a = _arrays(x, sample_rate=80000.0)
    # the last 6 cycles (8000 samples): a sine's mean over whole cycles is zero
    assert pfc.line_current_mean_A(a) == pytest.approx(0.0, abs=1e-12)
    assert pfc.line_power_factor(a) == pytest.approx(1.0)
    with pytest.raises(ValueError, match='whole number'):
        pfc.line_power_factor(_arrays(x[:1333], sample_rate=80000.0))
