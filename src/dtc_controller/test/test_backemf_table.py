import math

import numpy as np
import pytest

from dtc_controller.core.backemf_table import HEADER, BackEmfTable, BackEmfTableError
from dtc_test_tables import K_FLAT, make_table


def test_write_load_roundtrip(tmp_path, trap_table):
    path = tmp_path / 'bemf.csv'
    trap_table.write(path)
    text = path.read_text().splitlines()
    assert text[0].startswith('# ') and HEADER in text
    loaded = BackEmfTable.load(path, expected_pole_pairs=2)
    assert loaded.points == 360 and loaded.pole_pairs == 2
    for th in (0.0, 0.123, 3.0, 6.2):
        assert loaded.k_alpha_beta(th) == pytest.approx(trap_table.k_alpha_beta(th))


def test_linear_interpolation_and_wrap():
    tab = make_table('sine', points=12)
    h = 2 * math.pi / 12
    k0, k1 = tab.columns['k_alpha'][0], tab.columns['k_alpha'][1]
    assert tab.k_alpha_beta(0.25 * h)[0] == pytest.approx(0.75 * k0 + 0.25 * k1)
    # between the last point and 2 pi the lookup wraps to the first point
    kl = tab.columns['k_alpha'][-1]
    assert tab.k_alpha_beta(11.5 * h)[0] == pytest.approx(0.5 * (kl + k0))
    assert tab.k_alpha_beta(-0.5 * h)[0] == pytest.approx(0.5 * (kl + k0))
    assert tab.k_abc(2 * math.pi + 0.3) == pytest.approx(tab.k_abc(0.3))


def test_rotor_flux_is_integral_of_k(sine_table):
    # k_a = -K sin(theta) -> psi_ra = K cos(theta), |psi_r| = K (eq. 2.19/2.20 reference)
    for th in (0.0, 1.0, 4.0):
        assert sine_table.rotor_flux(th) == pytest.approx((K_FLAT * math.cos(th), K_FLAT * math.sin(th)), abs=2e-5)
        assert sine_table.rotor_flux_magnitude(th) == pytest.approx(K_FLAT, rel=1e-3)


def _write(tmp_path, text):
    p = tmp_path / 'bad.csv'
    p.write_text(text)
    return p


def _good_text(tab):
    rows = np.column_stack([tab.columns[c] for c in HEADER.split(',')])
    return '\n'.join(['# pole_pairs: 2', f'# points: {len(rows)}', HEADER]
                     + [','.join(repr(float(v)) for v in r) for r in rows]) + '\n'


@pytest.mark.parametrize('mutate, problem', [
    (lambda t: t.replace(HEADER, 'theta,k_a,k_b'), 'header'),
    (lambda t: t.replace('# points: 36', '# points: 37'), 'points: 37'),
    (lambda t: t.replace('# pole_pairs: 2\n', ''), 'pole_pairs'),
    (lambda t: t.rstrip('\n').rsplit('\n', 1)[0] + '\n', 'rows'),
    (lambda t: t.replace(HEADER + '\n', HEADER + '\nfoo\n', 1), 'cells'),
])
def test_malformed_file_names_file_and_problem(tmp_path, mutate, problem):
    p = _write(tmp_path, mutate(_good_text(make_table(points=36))))
    with pytest.raises(BackEmfTableError) as err:
        BackEmfTable.load(p)
    assert str(p) in str(err.value) and problem in str(err.value)


def test_mismatched_columns_and_motor_rejected(tmp_path):
    tab = make_table(points=36)
    tab.columns['k_alpha'] = tab.columns['k_alpha'] * 1.5  # not the Clarke of k_a, k_b, k_c
    p = _write(tmp_path, _good_text(tab))
    with pytest.raises(BackEmfTableError, match='k_alpha'):
        BackEmfTable.load(p)
    good = _write(tmp_path, _good_text(make_table(points=36)))
    with pytest.raises(BackEmfTableError, match='pole_pairs 2'):
        BackEmfTable.load(good, expected_pole_pairs=4)
    with pytest.raises(BackEmfTableError, match='cannot read'):
        BackEmfTable.load(tmp_path / 'missing.csv')


def test_uneven_angles_rejected(tmp_path):
    tab = make_table(points=36)
    tab.columns['theta_e'] = tab.columns['theta_e'] * 0.99
    with pytest.raises(BackEmfTableError, match='evenly spaced'):
        BackEmfTable.load(_write(tmp_path, _good_text(tab)))
