from dtc_controller.core.hysteresis import two_level


def test_two_level_holds_inside_band():
    state, out = -1, []
    for e in (0.05, 0.11, 0.0, -0.09, -0.11, 0.09):
        state = two_level(state, 0.1, e)
        out.append(state)
    assert out == [-1, 1, 1, 1, -1, -1]
    assert two_level(-1, 0.0, 1e-9) == 1
