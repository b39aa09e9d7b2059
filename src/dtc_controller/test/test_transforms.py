import pytest

from dtc_controller.core import transforms as tf
from drive_common.signals import clarke


def test_line_to_line_recovers_alpha_beta():
    a, b, c = 0.4, 0.5, -0.9
    assert tf.alpha_beta_from_line_to_line(b - a, c - a) == pytest.approx(clarke(a, b, c))


def test_reconstruct_missing_current():
    nan = float('nan')
    assert tf.reconstruct_currents(1.0, nan, -3.0) == (1.0, 2.0, -3.0)
    assert tf.reconstruct_currents(nan, 1.0, 2.0) == (-3.0, 1.0, 2.0)
    assert tf.reconstruct_currents(1.0, 2.0, nan) == (1.0, 2.0, -3.0)
    with pytest.raises(ValueError):
        tf.reconstruct_currents(nan, nan, 1.0)
