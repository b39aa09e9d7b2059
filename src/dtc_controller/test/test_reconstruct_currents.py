import pytest

from dtc_controller.core.modes.regulation import reconstruct_currents


def test_reconstruct_missing_current():
    nan = float('nan')
    assert reconstruct_currents(1.0, nan, -3.0) == (1.0, 2.0, -3.0)
    assert reconstruct_currents(nan, 1.0, 2.0) == (-3.0, 1.0, 2.0)
    assert reconstruct_currents(1.0, 2.0, nan) == (1.0, 2.0, -3.0)
    with pytest.raises(ValueError):
        reconstruct_currents(nan, nan, 1.0)
