"""Feed-forward of eqs. (3.2)-(3.6): line-period average, C, K_m, and the A*B*C product."""
import math

import numpy as np
import pytest

from drive_common.samples import PfcSample
from pfc_controller.core import PfcCore
from pfc_controller.core.feedforward import LinePeriodAverage, feedforward_c

T_S = 12.5e-6


def test_line_period_average_of_rectified_sine_is_2_over_pi():
    avg = LinePeriodAverage(60.0, T_S)
    assert avg.window == pytest.approx(80000 / 60)
    n = 5 * 1334
    values = [avg.update(abs(math.sin(2 * math.pi * 60 * k * T_S))) for k in range(n)]
    tail = np.array(values[-2000:])
    # Fractional window: no 120 Hz ripple left in the average (an integer window leaves ~1e-4).
    assert np.ptp(tail) < 2e-5
    assert tail.mean() == pytest.approx(2 / math.pi, rel=1e-4)


def test_line_period_average_warm_up_and_step():
    avg = LinePeriodAverage(50.0, 1e-3)    # 20 samples per period
    assert avg.update(3.0) == 3.0
    assert avg.update(1.0) == 2.0
    for _ in range(30):
        out = avg.update(5.0)
    assert out == pytest.approx(5.0)


def test_feedforward_c_eq_3_5_and_clamp():
    km = 2.5
    # Line at V_min: V_dc(pu) = 2/(pi Km) -> C = 1; at V_max: C = 1/Km^2.
    assert feedforward_c(2 / (math.pi * km), km) == pytest.approx(1.0)
    assert feedforward_c(2 / math.pi, km) == pytest.approx(1 / km ** 2)
    assert feedforward_c(0.0, km) == pytest.approx(1.0)          # start-up clamp
    vdc = 0.5
    assert feedforward_c(vdc, km) == pytest.approx(4 / (math.pi * vdc * km) ** 2)


@pytest.mark.parametrize('v_rms', [20.0, 25.4, 50.0])
def test_per_unit_a_b_c_give_the_reference_of_eq_3_1(v_rms):
    """I_ref = K_m A B C I_base = B I_base (V_min / V_p)|sin|, i.e. P_in = B V_min I_base / 2."""
    core = PfcCore({'voltage_reference_ramp_rate': 0.0})
    v_p = v_rms * math.sqrt(2)
    km = 70.71 / 28.28
    assert core.km == pytest.approx(km)
    rows = []
    for k in range(3 * 1334):
        s = abs(math.sin(2 * math.pi * 60 * k * T_S))
        _, st = core.update(PfcSample(k, k * T_S, v_p * s, 0.0, 79.0))
        rows.append((s, st))
    for s, st in rows[-1334:]:
        assert st.input_per_unit == pytest.approx(v_p * s / 70.71)
        vdc_pu = 2 * v_p / (math.pi * 70.71)
        assert st.feedforward == pytest.approx(4 / (math.pi * vdc_pu * km) ** 2, rel=1e-3)
        assert st.current_reference == pytest.approx(
            km * st.input_per_unit * st.voltage_loop_output * st.feedforward * 10.0, rel=1e-9)
        assert st.current_reference == pytest.approx(
            st.voltage_loop_output * 10.0 * 28.28 / v_p * s, rel=1e-3, abs=1e-9)
