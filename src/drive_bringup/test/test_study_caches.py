"""Per-process caches of motor files, back-EMF tables and shapes (drive_common.file_cache):
shared by the cores of many points, re-read when a file changes, rebuilt when a parameter does."""
import shutil

import numpy as np
import pytest

from bldc_plant_sim.core.backemf import BackEmfShape
from bldc_plant_sim.parameters import MOTORS_DIR, load_motor_file
from dtc_controller.core.backemf_table import BackEmfTable

TABLE = MOTORS_DIR / 'ozturk_bldc_backemf.csv'


def test_an_edited_motor_file_is_read_again_and_callers_get_copies(tmp_path):
    path = tmp_path / 'motor.yaml'
    text = (MOTORS_DIR / 'ozturk_bldc.yaml').read_text()
    path.write_text(text)
    first = load_motor_file(str(path))
    assert first['motor.resistance'] == 0.315
    first['motor.resistance'] = 99.0                      # a caller's change stays its own
    first['motor.backemf.phase_gain'].append(5.0)
    again = load_motor_file(str(path))
    assert again['motor.resistance'] == 0.315 and again['motor.backemf.phase_gain'] == [1.0, 1.0, 1.0]
    path.write_text(text.replace('0.315', '0.316'))       # same size, rewritten at once
    assert load_motor_file(str(path))['motor.resistance'] == 0.316


def test_back_emf_tables_are_shared_read_only_and_reloaded_when_edited(tmp_path):
    path = tmp_path / 'table.csv'
    shutil.copy(TABLE, path)
    a, b = BackEmfTable.load(path, 2), BackEmfTable.load(path, 2)
    assert a is b                                          # one load serves every core
    with pytest.raises(ValueError):
        a.columns['k_a'][0] = 1.0
    with pytest.raises(ValueError, match='pole_pairs'):   # the check is part of the key
        BackEmfTable.load(path, 3)
    lines = path.read_text().splitlines()
    head = sum(1 for line in lines if line.startswith('#')) + 1
    rows = [[float(c) for c in line.split(',')] for line in lines[head:]]
    scaled = lines[:head] + [','.join(repr(v if j == 0 else 2.0 * v) for j, v in enumerate(r)) for r in rows]
    path.write_text('\n'.join(scaled) + '\n')
    c = BackEmfTable.load(path, 2)
    assert c is not a
    np.testing.assert_allclose(c.columns['k_a'], 2.0 * a.columns['k_a'])


def test_shape_tables_are_shared_per_parameters_and_rebuilt_when_one_changes():
    a = BackEmfShape('trapezoid', 0.0573)
    b = BackEmfShape('trapezoid', 0.0573)
    c = BackEmfShape('trapezoid', 0.06)
    assert a.lut_k is b.lut_k and not a.k_grid.flags.writeable
    np.testing.assert_allclose(c.k_grid, a.k_grid * (0.06 / 0.0573))
    table = BackEmfShape('table', 0.0, table_file=str(TABLE))
    assert table.lut_k is BackEmfShape('table', 0.0, table_file=str(TABLE)).lut_k
    assert table.lookup(0.4) == pytest.approx(table.k_abc(0.4)[:, 0], abs=1e-4)
