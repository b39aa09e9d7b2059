from dtc_controller.core.hysteresis import TwoLevelHysteresis


def test_two_level_holds_inside_band():
    h = TwoLevelHysteresis(0.1, initial=-1)
    assert [h.update(e) for e in (0.05, 0.11, 0.0, -0.09, -0.11, 0.09)] == [-1, 1, 1, 1, -1, -1]
    h.band = 0.0
    assert h.update(1e-9) == 1

