"""Back-EMF shapes, the alpha-beta rotor flux of the ideal trapezoid (000 E.9) and the generator test."""
from __future__ import annotations

import math

import numpy as np
import pytest

from bldc_plant_sim.backemf_generator import generator_test, main, table_columns
from bldc_plant_sim.core.backemf import (BackEmfShape, read_line_to_line_table, rotor_flux_alpha_beta,
                                         trapezoid_harmonics, trapezoid_unit)
from bldc_plant_sim.parameters import plant_params

K = 0.0573


def test_ideal_trapezoid_has_a_120_degree_flat_top_and_the_project_phase_convention():
    shape = BackEmfShape('trapezoid', K)
    th = np.radians([0, 15, 30, 90, 150, 165, 180, 270])
    k = shape.k_abc(th)
    np.testing.assert_allclose(k[0], [0, -K / 2, -K, -K, -K, -K / 2, 0, K], atol=1e-15)
    # phase b lags a by 120 degrees
    np.testing.assert_allclose(shape.k_abc(th + 2 * math.pi / 3)[1], k[0], atol=1e-15)
    # PM flux of phase a is maximal at theta_e = 0
    assert np.argmax(shape.psi_grid[0]) == 0


def test_trapezoid_series_coefficients():
    assert trapezoid_harmonics([1, 3, 5, 2]) == pytest.approx([1.0, 2 / 9, 1 / 25, 0.0])
    orders = tuple(range(1, 100, 2))
    shape = BackEmfShape('harmonic', 1.0, orders, tuple(trapezoid_harmonics(orders)))
    th = np.linspace(0, 2 * math.pi, 721)
    unit = -trapezoid_unit(th) / (12 / math.pi ** 2)             # K = fundamental peak
    assert np.max(np.abs(shape.k_abc(th)[0] - unit)) < 0.01     # series converges to the trapezoid


def test_alpha_beta_rotor_flux_of_ideal_trapezoid_and_000_eq_E9():
    shape = BackEmfShape('trapezoid', K)
    k_ll = shape.line_to_line_peak()
    assert k_ll == pytest.approx(2 * K)
    theta, psi_a, psi_b = rotor_flux_alpha_beta(shape)
    # project convention: psi_r at theta_e = 0 lies on alpha with 7 pi k_LL / 36
    assert psi_a[0] == pytest.approx(7 * math.pi * k_ll / 36, rel=1e-9)
    assert abs(psi_b[0]) < 1e-12
    # 000 (E.1) frame = project frame rotated by +30 deg (same magnitude)
    alpha_p = psi_a * math.cos(math.pi / 6) - psi_b * math.sin(math.pi / 6)
    e9 = 2 * math.pi * k_ll / (3 * math.sqrt(3))
    assert alpha_p.max() - alpha_p.min() == pytest.approx(e9, rel=1e-9)   # E.9 = peak-to-peak
    assert alpha_p.max() == pytest.approx(e9 / 2, rel=1e-9)
    mag = np.hypot(psi_a, psi_b)
    assert mag.min() == pytest.approx(e9 / 2, rel=1e-6) and mag.max() == pytest.approx(psi_a[0], rel=1e-9)
    # E.1 applied to the line-to-line EMFs equals that rotation of the project's Clarke
    ka, kb, kc = shape.k_grid
    e1_alpha = (2 * (ka - kb) - (kb - kc) - (kc - ka)) / (3 * math.sqrt(3))
    e1_beta = ((kb - kc) - (kc - ka)) / 3
    k_alpha, k_beta = (2 * ka - kb - kc) / 3, (kb - kc) / math.sqrt(3)
    c, s = math.cos(math.pi / 6), math.sin(math.pi / 6)
    np.testing.assert_allclose(e1_alpha, c * k_alpha - s * k_beta, atol=1e-15)
    np.testing.assert_allclose(e1_beta, s * k_alpha + c * k_beta, atol=1e-15)


def test_hall_code_follows_the_fundamental_of_each_phase():
    shape = BackEmfShape('trapezoid', K)
    codes = [shape.hall_code((n + 0.5) * math.pi / 3) for n in range(6)]
    assert sorted(codes) == [1, 2, 3, 4, 5, 6]
    for n, code in enumerate(codes):
        th = (n + 0.5) * math.pi / 3
        want = [int(-math.sin(th - s) > 0) for s in (0, 2 * math.pi / 3, 4 * math.pi / 3)]
        assert code == want[0] | want[1] << 1 | want[2] << 2


@pytest.mark.parametrize('motor', ['ozturk_bldc', 'ozturk_bldc_nonideal', 'fstp_pm_blac'])
def test_generator_test_reproduces_the_configured_shape(motor):
    params = plant_params(motor)
    result = generator_test(params, points=252, speed=20.0)
    cols = result['columns']
    shape = BackEmfShape.from_params(params)
    k = shape.k_abc(cols['theta_e'])
    peak = np.max(np.abs(k[1] - k[0]))
    assert np.max(np.abs(cols['k_ba'] - (k[1] - k[0]))) < 0.005 * peak
    assert np.max(np.abs(cols['k_ca'] - (k[2] - k[0]))) < 0.005 * peak
    zero_seq = k.mean(axis=0)
    assert np.max(np.abs(cols['k_a'] - (k[0] - zero_seq))) < 0.005 * peak


def test_generator_refuses_a_speed_that_forward_biases_the_diodes():
    with pytest.raises(ValueError, match='forward-bias'):
        generator_test(plant_params('ozturk_bldc'), points=252, speed=400.0)


def test_generator_cli_writes_the_table_file_and_table_shape_round_trips(tmp_path):
    out = tmp_path / 'table.csv'
    assert main(['--motor', 'ozturk_bldc_nonideal', '-o', str(out)]) == 0
    text = out.read_text().splitlines()
    assert '# pole_pairs: 2' in text and '# points: 252' in text
    header = [ln for ln in text if not ln.startswith('#')][0]
    assert header == 'theta_e,k_a,k_b,k_c,k_ba,k_ca,k_alpha,k_beta,k_d,k_q'
    theta, k_ba, k_ca, meta = read_line_to_line_table(out)
    assert len(theta) == 252 and theta[1] == pytest.approx(2 * math.pi / 252)
    # a motor using the written table as its shape gives the same table back
    params = plant_params('ozturk_bldc', **{'motor.backemf.shape': 'table',
                                            'motor.backemf.table_file': str(out)})
    again = generator_test(params, points=252, speed=20.0)['columns']
    # (the 252-point table is re-gridded onto the 3072-point lookup table: ~1e-4 interpolation)
    np.testing.assert_allclose(again['k_ba'], k_ba, rtol=0, atol=2e-4 * np.max(np.abs(k_ba)))
    cols = table_columns(k_ba, k_ca)
    np.testing.assert_allclose(cols['k_alpha'] ** 2 + cols['k_beta'] ** 2,
                               cols['k_d'] ** 2 + cols['k_q'] ** 2, rtol=1e-9)
