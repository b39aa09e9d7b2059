"""Design studies: validation, sampling plans, point status, resume (in-process Dask client)."""
import dataclasses
import json
import re
import subprocess
import sys
import textwrap

import pandas as pd
import pytest
import yaml

from drive_bringup.study import (JOURNAL, StudyError, load_study, read_journal, run_point,
                                 run_study, sample, Axis)
from drive_bringup import study
from drive_bringup.study_cli import study_dir

BASE = '''
    name: probe
    scenario: two_phase_six_switch_torque_step
    duration: 0.003
    parameters:
      - name: load_N_m
        targets: [plant.load.torque]
        values: [0.1, 0.2, 0.3]
    metrics:
      mean_torque_N_m: {t_start: 0.001}
      peak_phase_current_A: {}
'''


def write(tmp_path, text: str, name: str = 'study.yaml'):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def test_grid_study_builds_one_validated_scenario_per_point(tmp_path):
    study = load_study(write(tmp_path, BASE))
    assert [p.values['load_N_m'] for p in study.points] == [0.1, 0.2, 0.3]
    assert [p.scenario.node_parameters['plant']['load.torque'] for p in study.points] == [0.1, 0.2, 0.3]
    assert all(p.scenario.duration == 0.003 for p in study.points)
    assert len({p.key for p in study.points}) == 3


def test_point_key_is_the_hash_of_the_full_parameters(tmp_path):
    a = load_study(write(tmp_path, BASE, 'a.yaml'))
    b = load_study(write(tmp_path, BASE.replace('duration: 0.003', 'duration: 0.004'), 'b.yaml'))
    assert [p.key for p in a.points] == [p.key for p in load_study(tmp_path / 'a.yaml').points]
    assert not {p.key for p in a.points} & {p.key for p in b.points}


@pytest.mark.parametrize('change, key, reason', [
    ('bogus: 1\n', 'bogus', 'unknown key'),
    ('sampling: sobol\n', 'sampling', 'not one of'),
    ('repeats: 0\n', 'repeats', 'integer >= 1'),
    ('timeout: -1\n', 'timeout', 'must be > 0'),
    ('set: {plant.no_such: 1}\n', 'set.plant.no_such', "no parameter 'no_such'"),
    ('set: {gripper.x: 1}\n', 'set.gripper.x', 'unknown target'),
    ('set: {"events[3].time": 0.001}\n', 'set.events[3].time', 'event(s)'),
    ('set: {"events[0].torque_reference": 0.3}\n', 'set.events[0].torque_reference', 'after duration'),
    ('set: {plant.load.torque: "heavy"}\n', 'set', 'plant'),
    ('metrics: {bogus_metric: {}}\n', 'metrics.bogus_metric', 'no metric named'),
    ('sampling: random\n', 'samples', 'required with sampling random'),
])
def test_errors_name_file_key_and_reason(tmp_path, change, key, reason):
    raw = {**yaml.safe_load(textwrap.dedent(BASE)), **yaml.safe_load(change)}
    path = write(tmp_path, yaml.safe_dump(raw))
    with pytest.raises(StudyError) as err:
        load_study(path)
    message = str(err.value)
    assert message.startswith(f'{path}: {key}: '), message
    assert reason in message, message


def test_a_value_the_node_refuses_names_the_point(tmp_path):
    path = write(tmp_path, BASE.replace('[0.1, 0.2, 0.3]', '[0.1, 5000.0]'))
    with pytest.raises(StudyError, match=r'parameters: point load_N_m=5000.0: plant: .*load.torque'):
        load_study(path)


def test_wrong_target_in_an_axis(tmp_path):
    path = write(tmp_path, BASE.replace('[plant.load.torque]', '[plant.load.torque, plant.nope]'))
    with pytest.raises(StudyError, match=r'parameters.load_N_m.targets\[1\]: .*no parameter'):
        load_study(path)


def test_cli_bad_study_exits_2_with_one_line(tmp_path):
    path = write(tmp_path, textwrap.dedent(BASE) + 'bogus: 1\n')
    proc = subprocess.run([sys.executable, '-m', 'drive_bringup.study_cli', str(path)],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.strip().count('\n') == 0 and 'bogus: unknown key' in proc.stderr
    assert 'Traceback' not in proc.stderr


def test_latin_hypercube_puts_one_sample_in_each_stratum():
    axes = [Axis('a', ('x',), low=0.0, high=1.0), Axis('b', ('y',), low=1.0, high=100.0, log=True)]
    points = sample(axes, 'latin_hypercube', samples=8, seed=3)
    assert sorted(int(p['a'] * 8) for p in points) == list(range(8))
    import math
    assert sorted(int(math.log10(p['b']) / 2 * 8) for p in points) == list(range(8))
    assert points == sample(axes, 'latin_hypercube', samples=8, seed=3)     # seeded
    assert points != sample(axes, 'latin_hypercube', samples=8, seed=4)


def test_zip_and_repeats(tmp_path):
    raw = yaml.safe_load(textwrap.dedent(BASE))
    raw['parameters'].append({'name': 'band', 'targets': ['dtc_controller.torque_band'],
                              'values': [0.001, 0.002, 0.003]})
    raw.update(sampling='zip', repeats=2)
    text = yaml.safe_dump(raw)
    study = load_study(write(tmp_path, text))
    assert [(p.values['load_N_m'], p.values['band'], p.repeat) for p in study.points] == [
        (0.1, 0.001, 0), (0.1, 0.001, 1), (0.2, 0.002, 0), (0.2, 0.002, 1),
        (0.3, 0.003, 0), (0.3, 0.003, 1)]
    assert [p.scenario.node_parameters['plant']['sensors.seed'] for p in study.points[:2]] == [0, 1]


def test_statuses_are_recorded_not_raised(tmp_path):
    study = load_study(write(tmp_path, BASE))
    point = study.points[0]
    ok = run_point(point)
    assert ok['status'] == 'ok' and ok['mean_torque_N_m'] > 0.0 and ok['wall_time_s'] > 0.0

    trip = dataclasses.replace(point, scenario=dataclasses.replace(
        point.scenario, node_parameters={**point.scenario.node_parameters, 'plant': {
            **point.scenario.node_parameters['plant'], 'protection.peak_current': 0.5}}))
    row = run_point(trip)
    assert row['status'] == 'protection_trip' and 'protection word' in row['reason']

    timed_out = run_point(point, timeout=1e-9)
    assert timed_out['status'] == 'timeout' and 'still running' in timed_out['reason']

    broken = dataclasses.replace(point, scenario=dataclasses.replace(
        point.scenario, node_parameters={'plant': {}, 'dtc_controller': {}}))
    row = run_point(broken)
    assert row['status'] == 'error' and re.match(r'\w+Error: ', row['reason'])


def test_resume_skips_the_points_already_done(tmp_path):
    from distributed import Client
    study = load_study(write(tmp_path, BASE))
    out = tmp_path / 'out'
    with Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=None) as client:
        first = run_study(study, out, client=client, progress=False, plots=False)
        assert (first.ran, first.skipped) == (3, 0)
        journal = (out / JOURNAL).read_text().splitlines()
        assert len(journal) == 3

        bigger = load_study(write(tmp_path, BASE.replace('[0.1, 0.2, 0.3]', '[0.1, 0.2, 0.3, 0.4]')))
        second = run_study(bigger, out, client=client, progress=False)
    assert (second.ran, second.skipped) == (1, 3)
    rows = [json.loads(line) for line in (out / JOURNAL).read_text().splitlines()]
    assert len(rows) == 4 and rows[-1]['load_N_m'] == 0.4      # only the new point was appended
    assert sorted(read_journal(out)) == sorted(p.key for p in bigger.points)
    table = pd.read_parquet(out / 'results.parquet')
    assert list(table['load_N_m']) == [0.1, 0.2, 0.3, 0.4]
    assert set(table['status']) == {'ok'} and table['git_revision'].str.len().min() > 0
    assert table['mean_torque_N_m'].notna().all()
    assert pd.read_csv(out / 'results.csv').shape == table.shape
    assert (out / 'plots' / 'mean_torque_N_m.png').stat().st_size > 0


def test_batch_size_balances_the_workers_and_is_bounded():
    assert [study.batch_size(n, 2) for n in (1, 15, 16, 100, 1000, 10 ** 6)] == [1, 1, 1, 6, 62, 64]
    assert study.batch_size(100, 0) == study.batch_size(100, 1) == 12


def test_points_run_in_batches_and_each_is_recorded_once(tmp_path, monkeypatch):
    from distributed import Client, get_task_stream
    loads = [round(0.01 * i, 2) for i in range(1, 21)]
    probe = load_study(write(tmp_path, BASE.replace('[0.1, 0.2, 0.3]', str(loads))))
    out = tmp_path / 'out'
    with Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=None) as client:
        with get_task_stream(client) as tasks:
            run = run_study(probe, out, client=client, progress=False, plots=False)
        assert len(tasks.data) == 10 and run.ran == 20            # 2 points per task on 1 worker
        rows = [json.loads(line) for line in (out / JOURNAL).read_text().splitlines()]
        assert sorted(r['key'] for r in rows) == sorted(p.key for p in probe.points)
        assert list(run.table['load_N_m']) == loads and set(run.table['status']) == {'ok'}

        def broken(points, timeout):
            raise RuntimeError('worker lost')
        monkeypatch.setattr(study, 'run_points', broken)
        again = run_study(probe, tmp_path / 'again', client=client, progress=False, plots=False)
    assert set(again.table['status']) == {'error'} and len(again.table) == 20   # every point of each batch
    assert set(again.table['reason']) == {'RuntimeError: worker lost'}


def test_shipped_studies_validate():
    paths = sorted(study_dir().glob('*.yaml'))
    assert len(paths) >= 2
    for path in paths:
        assert load_study(path).points


def test_cli_on_a_local_cluster_records_a_protection_trip_and_samples_randomly(tmp_path):
    raw = yaml.safe_load(textwrap.dedent(BASE))
    raw['parameters'] = [
        {'name': 'peak_current_A', 'targets': ['plant.protection.peak_current'], 'min': 0.2, 'max': 40.0,
         'log': True},
        {'name': 'load_N_m', 'targets': ['plant.load.torque'], 'min': 0.0, 'max': 0.3}]
    raw.update(sampling='random', samples=4, seed=7)
    path = write(tmp_path, yaml.safe_dump(raw))
    study = load_study(path)
    out = tmp_path / 'out'
    proc = subprocess.run([sys.executable, '-m', 'drive_bringup.study_cli', str(path), '--workers', '1',
                           '--out', str(out), '--no-progress'], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    table = pd.read_parquet(out / 'results.parquet')
    assert list(table['key']) == [p.key for p in study.points]
    expected = ['protection_trip' if p.values['peak_current_A'] < 2.0 else 'ok' for p in study.points]
    assert list(table['status']) == expected and set(expected) == {'ok', 'protection_trip'}
    assert f'protection_trip {expected.count("protection_trip")}' in proc.stdout   # the summary


def test_a_study_sweeps_your_own_controller_by_its_schema(tmp_path):
    study = load_study(write(tmp_path, '''
        name: own
        scenario: example_hysteresis_current_control
        duration: 0.01
        parameters:
          - name: band_A
            targets: [controller.current_band]
            values: [0.1, 0.4]
    '''))
    assert [p.scenario.node_parameters['controller']['current_band'] for p in study.points] == [0.1, 0.4]
    assert len({p.key for p in study.points}) == 2
    with pytest.raises(StudyError, match='controller has no parameter'):
        load_study(write(tmp_path, '''
            name: own
            scenario: example_hysteresis_current_control
            parameters: [{name: x, targets: [controller.no_such], values: [1.0]}]
        ''', 'bad.yaml'))
