"""PiController: series (pid_reg3) form, limits and anti-windup."""
import pytest

from pfc_controller.core.pi import PiController


def test_series_form_step_response():
    pi = PiController(kp=0.5, ki=0.1, out_min=-10.0, out_max=10.0)
    # u[k] = Kp e + x[k], x[k] = x[k-1] + Ki Kp e: integral slope Kp*Ki per sample.
    outputs = [pi.update(1.0) for _ in range(4)]
    assert outputs == pytest.approx([0.55, 0.60, 0.65, 0.70])
    assert not pi.saturated


def test_output_limits_and_flag():
    pi = PiController(kp=2.0, ki=0.0, out_min=-1.0, out_max=1.0)
    assert pi.update(5.0) == 1.0 and pi.saturated
    assert pi.update(-5.0) == -1.0 and pi.saturated
    assert pi.update(0.25) == pytest.approx(0.5) and not pi.saturated
    assert pi.update(5.0, out_max=0.3) == 0.3     # per-call limits


def test_anti_windup_recovers_at_once():
    """After a long saturation the output leaves the limit as soon as the error reverses."""
    pi = PiController(kp=0.1, ki=0.5, out_min=0.0, out_max=1.0)
    for _ in range(10000):
        assert pi.update(1.0) <= 1.0
    assert pi.saturated
    assert pi.integral == pytest.approx(0.9)      # just enough to hold the limit
    out = pi.update(-0.5)                         # (unclamped it would be ~500)
    assert out == pytest.approx(-0.05 + 0.9 - 0.025) and not pi.saturated


def test_proportional_saturation_does_not_charge_the_integrator():
    pi = PiController(kp=1.0, ki=0.5, out_min=0.0, out_max=1.0)
    for _ in range(100):
        pi.update(10.0)
    assert pi.integral == 0.0


def test_integrator_frozen_only_in_the_winding_direction():
    pi = PiController(kp=1.0, ki=0.1, out_min=0.0, out_max=1.0)
    pi.reset(integral=1.0)
    assert pi.update(1.0) == 1.0 and pi.saturated
    assert pi.integral == pytest.approx(1.0)      # would wind up: frozen
    pi.update(-0.2)
    assert pi.integral == pytest.approx(0.98)     # unwinds normally


def test_reversed_limits_rejected():
    with pytest.raises(ValueError):
        PiController(1.0, 0.1, 1.0, 0.0)
