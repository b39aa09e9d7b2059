"""Studies on a real Dask cluster: `dask scheduler` + two `dask worker` programs on localhost.

The study runs through ``study --scheduler tcp://127.0.0.1:<free port>`` as a
separate program; one test kills a worker once the study is under way and
checks that every point is still in the results exactly once.
"""
import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pandas as pd
import pytest

from drive_bringup.dask_programs import DaskPrograms
from drive_bringup.study import JOURNAL, load_study
from drive_testing.harness import wait_until

STUDY = '''
    name: cluster_probe
    scenario: two_phase_six_switch_torque_step
    duration: {duration}
    parameters:
      - name: load_N_m
        targets: [plant.load.torque]
        values: {values}
    metrics:
      mean_torque_N_m: {{}}
'''


@pytest.fixture
def cluster(tmp_path):
    with DaskPrograms(tmp_path / 'cluster', workers=2) as programs:
        yield programs


def start_study(tmp_path, cluster, duration: float, values: list[float]):
    path = tmp_path / 'study.yaml'
    path.write_text(textwrap.dedent(STUDY.format(duration=duration, values=values)))
    out = tmp_path / 'out'
    proc = subprocess.Popen([sys.executable, '-m', 'drive_bringup.study_cli', str(path), '--scheduler',
                             cluster.address, '--out', str(out), '--no-progress'],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    return load_study(path), out, proc


def journal_rows(out: Path) -> list[dict]:
    path = out / JOURNAL
    return [json.loads(line) for line in path.read_text().splitlines()] if path.exists() else []


def test_study_runs_on_a_separately_started_cluster(tmp_path, cluster):
    study, out, proc = start_study(tmp_path, cluster, 0.004, [0.1, 0.2, 0.3, 0.4])
    output, _ = proc.communicate(timeout=240)
    assert proc.returncode == 0, output
    table = pd.read_parquet(out / 'results.parquet')
    assert sorted(table['key']) == sorted(p.key for p in study.points)
    assert set(table['status']) == {'ok'}
    workers = set(table['worker'])
    assert all(w.split(':')[-1].isdigit() for w in workers)
    assert {str(cluster.pid(f'worker{i}')) for i in range(2)} >= {w.split(':')[-1] for w in workers}
    cluster.close()   # each program ends on its SIGTERM (exit 0), none needs the SIGKILL
    assert {name: proc.returncode for name, proc in cluster.procs.items()} == {
        'scheduler': 0, 'worker0': 0, 'worker1': 0}


def test_killing_a_worker_mid_study_still_runs_every_point_once(tmp_path, cluster):
    values = [round(0.05 * i, 2) for i in range(1, 9)]
    study, out, proc = start_study(tmp_path, cluster, 0.06, values)
    try:
        wait_until(lambda: len(journal_rows(out)) >= 1 or proc.poll() is not None, timeout=240.0)
        assert proc.poll() is None, 'the study finished before a worker could be killed'
        cluster.kill('worker0')
        output, _ = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, output
    rows = journal_rows(out)
    assert sorted(r['key'] for r in rows) == sorted(p.key for p in study.points)   # each once
    table = pd.read_parquet(out / 'results.parquet')
    assert len(table) == len(values) and set(table['status']) == {'ok'}
    assert str(cluster.pid('worker1')) in {w.split(':')[-1] for w in table['worker']}
