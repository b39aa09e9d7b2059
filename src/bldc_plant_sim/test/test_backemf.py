"""Back-EMF shapes, the alpha-beta rotor flux of the ideal trapezoid (000 E.9) and the generator test."""
from __future__ import annotations

import math

import numpy as np
import pytest

from bldc_plant_sim.backemf_generator import generator_test, main
from bldc_plant_sim.core.backemf import (BackEmfShape, rotor_flux_alpha_beta,
                                         trapezoid_harmonics, trapezoid_unit)
from bldc_plant_sim.core.plant import PlantCore
from bldc_plant_sim.parameters import plant_params
from drive_common import backemf_file

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


def _analytic_phase_constants(params, theta):
    """(k_a, k_b, k_c) [V s/rad] of a motor file's shape, from the formulas (not the plant's code).

    trapezoid: flat top K on [30, 150] deg, linear 30-deg ramps through zero, odd: the unit
    waveform through the corners (0, 0), (pi/6, 1), (5 pi/6, 1), (7 pi/6, -1), (11 pi/6, -1),
    (2 pi, 0); k_a = -K * unit. harmonic: k_a = -K sum_n c_n sin(n theta). Phases b, c lag by
    120 / 240 deg and carry their gains.
    """
    K = params['motor.backemf.constant']
    corners_x = np.array([0, 1, 5, 7, 11, 12]) * math.pi / 6
    corners_y = np.array([0, 1, 1, -1, -1, 0], dtype=float)
    out = []
    for shift, gain in zip((0.0, 2 * math.pi / 3, 4 * math.pi / 3), params['motor.backemf.phase_gain']):
        th = np.mod(theta - shift, 2 * math.pi)
        if params['motor.backemf.shape'] == 'trapezoid':
            k = -K * np.interp(th, corners_x, corners_y)
        else:
            assert params['motor.backemf.shape'] == 'harmonic'
            k = -K * sum(c * np.sin(n * th) for n, c in zip(params['motor.backemf.harmonic_orders'],
                                                           params['motor.backemf.harmonic_coefficients']))
        out.append(gain * k)
    return out


@pytest.mark.parametrize('motor', ['ozturk_bldc', 'ozturk_bldc_nonideal', 'fstp_pm_blac'])
def test_generator_test_reproduces_the_analytic_shape(motor):
    # The generator reads terminal voltages the plant computes from its lookup table; the
    # reference here is the shape evaluated directly from its formula, so an error in the
    # table (shape code, interpolation, phase order or shift, gains) shows.
    params = plant_params(motor)
    result = generator_test(params, points=252, speed=20.0)
    cols = result['columns']
    ka, kb, kc = _analytic_phase_constants(params, cols['theta_e'])
    peak = np.max(np.abs(kb - ka))
    assert np.max(np.abs(cols['k_ba'] - (kb - ka))) < 1e-4 * peak
    assert np.max(np.abs(cols['k_ca'] - (kc - ka))) < 1e-4 * peak
    zero_seq = (ka + kb + kc) / 3
    assert np.max(np.abs(cols['k_a'] - (ka - zero_seq))) < 1e-4 * peak
    if motor == 'ozturk_bldc':     # 000 App. A: line-to-line peak = lambda_f, flat top 60 deg wide
        assert np.max(cols['k_ba']) == pytest.approx(0.1146, rel=1e-9)


def test_generator_refuses_a_speed_that_forward_biases_the_diodes():
    with pytest.raises(ValueError, match='forward-bias'):
        generator_test(plant_params('ozturk_bldc'), points=252, speed=600.0)


def test_generator_cli_writes_the_table_file_and_table_shape_round_trips(tmp_path):
    out = tmp_path / 'table.csv'
    assert main(['--motor', 'ozturk_bldc_nonideal', '-o', str(out)]) == 0
    text = out.read_text().splitlines()
    assert '# pole_pairs: 2' in text and '# points: 252' in text
    header = [ln for ln in text if not ln.startswith('#')][0]
    assert header == 'theta_e,k_a,k_b,k_c,k_ba,k_ca,k_alpha,k_beta,k_d,k_q'
    theta, k_ba, k_ca, meta = _read(out)
    assert len(theta) == 252 and theta[1] == pytest.approx(2 * math.pi / 252)
    # a motor using the written table as its shape gives the same table back
    params = plant_params('ozturk_bldc', **{'motor.backemf.shape': 'table',
                                            'motor.backemf.table_file': str(out)})
    again = generator_test(params, points=252, speed=20.0)['columns']
    # (the 252-point table is re-gridded onto the 3072-point lookup table: ~1e-4 interpolation)
    np.testing.assert_allclose(again['k_ba'], k_ba, rtol=0, atol=2e-4 * np.max(np.abs(k_ba)))
    cols = backemf_file.columns_from_line_to_line(k_ba, k_ca)
    np.testing.assert_allclose(cols['k_alpha'] ** 2 + cols['k_beta'] ** 2,
                               cols['k_d'] ** 2 + cols['k_q'] ** 2, rtol=1e-9)


def _read(path):
    table = backemf_file.read(path)
    return (table.columns['theta_e'], table.columns['k_ba'], table.columns['k_ca'], table.metadata)


# ---- back-EMF table files the plant reads: checked, every error names path and line --------

def _good_table(tmp_path, points=24):
    theta = np.arange(points) * (2 * math.pi / points)
    shape = BackEmfShape('trapezoid', K)
    k = shape.k_abc(theta)
    path = tmp_path / 'table.csv'
    backemf_file.write(path, backemf_file.columns_from_line_to_line(k[1] - k[0], k[2] - k[0]),
                      {'pole_pairs': 2, 'points': points})
    return path


def _edit(path, fn):
    lines = path.read_text().splitlines()
    path.write_text('\n'.join(fn(lines)) + '\n')
    return path


def _data_start(lines):
    return next(n for n, ln in enumerate(lines) if not ln.startswith('#')) + 1


def _set_cell(lines, row, col, value):
    n = _data_start(lines) + row
    cells = lines[n].split(',')
    cells[col] = value
    lines[n] = ','.join(cells)
    return lines


def test_a_good_table_is_read(tmp_path):
    theta, k_ba, k_ca, meta = _read(_good_table(tmp_path))
    assert len(theta) == 24 and meta['points'] == '24'


@pytest.mark.parametrize('edit, line_of, reason', [
    # out of order: rows 5 and 6 swapped
    (lambda ls: ls[:_data_start(ls) + 5] + [ls[_data_start(ls) + 6], ls[_data_start(ls) + 5]]
     + ls[_data_start(ls) + 7:], 6, 'does not increase'),
    # a single row
    (lambda ls: [ln for ln in ls[:_data_start(ls) + 1] if not ln.startswith('# points')], 0,
     'at least 12'),
    (lambda ls: _set_cell(ls, 3, 4, 'nan'), 3, 'not finite'),
    (lambda ls: _set_cell(ls, 3, 5, 'inf'), 3, 'not finite'),
    (lambda ls: _set_cell(ls, 7, 4, 'abc'), 7, "'abc' is not a number"),
    (lambda ls: _set_cell(ls, 2, 4, ''), 2, 'is not a number'),
    (lambda ls: [ln if n < _data_start(ls) else ln + ',1.0' for n, ln in enumerate(ls)], 0, 'cells'),
    (lambda ls: [ls[0]] + [ln for ln in ls[1:] if not ln.startswith('# points')], 23, 'degrees'),
    (lambda ls: _set_cell(ls, 0, 0, '-0.1'), 0, 'negative'),
    (lambda ls: [ln for n, ln in enumerate(ls) if n != _data_start(ls) + 23], 22, 'points'),
])
def test_bad_tables_are_refused_with_path_and_line(tmp_path, edit, line_of, reason):
    path = _edit(_good_table(tmp_path), edit)
    if reason == 'degrees':   # the same table with theta_e in degrees
        lines = path.read_text().splitlines()
        start = _data_start(lines)
        for n in range(start, len(lines)):
            cells = lines[n].split(',')
            cells[0] = repr(math.degrees(float(cells[0])))
            lines[n] = ','.join(cells)
        path.write_text('\n'.join(lines) + '\n')
    line = _data_start(path.read_text().splitlines()) + 1 + line_of
    with pytest.raises(ValueError, match=reason) as err:
        backemf_file.read(path)
    assert str(err.value).startswith(f'{path}:{line}: '), str(err.value)
    # the plant refuses the same file when it is its back-EMF shape
    with pytest.raises(ValueError, match=reason):
        PlantCore(plant_params('ozturk_bldc', **{'motor.backemf.shape': 'table',
                                                 'motor.backemf.table_file': str(path)}))


def test_missing_header_column_names_the_line(tmp_path):
    path = _edit(_good_table(tmp_path), lambda ls: [ln.replace('k_ca', 'k_cx') for ln in ls])
    with pytest.raises(ValueError, match=r'table\.csv:\d+: back-EMF table header lacks column k_ca'):
        backemf_file.read(path)


def test_shipped_tables_pass_the_checks():
    from bldc_plant_sim.parameters import MOTORS_DIR
    for path in sorted(MOTORS_DIR.glob('*.csv')):
        theta, _, _, meta = _read(path)
        assert len(theta) == int(meta['points'])
