"""Studies on a real Dask cluster: `dask scheduler` + two `dask worker` programs on localhost.

The study runs through ``study --scheduler tcp://127.0.0.1:<free port>`` as a
separate program; one test kills a worker once the study is under way and
checks that every point is still in the results exactly once.
"""
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import textwrap
from pathlib import Path

import pandas as pd
import pytest

from drive_bringup.study import JOURNAL, load_study
from drive_common.harness import wait_until

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


def free_port() -> int:
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def dask_program() -> str:
    path = shutil.which('dask', path=str(Path(sys.executable).parent) + os.pathsep + os.environ['PATH'])
    if path is None:
        pytest.fail('the dask command (from the pinned dask package) is not installed')
    return path


class Cluster:
    """A scheduler and named workers, each its own process group (ended by pid)."""

    def __init__(self, tmp_path: Path, workers: int = 2) -> None:
        self.port = free_port()
        self.address = f'tcp://127.0.0.1:{self.port}'
        self.logs = tmp_path
        self.procs = {}
        self._start('scheduler', 'scheduler', '--host', '127.0.0.1', '--port', str(self.port),
                    '--no-dashboard')
        for i in range(workers):
            self._start(f'worker{i}', 'worker', self.address, '--nworkers', '1', '--nthreads', '1',
                        '--no-nanny', '--no-dashboard', '--name', f'worker{i}',
                        '--local-directory', str(tmp_path / f'worker{i}'))
        from distributed import Client
        with Client(self.address, timeout='60s') as client:
            wait_until(lambda: len(client.scheduler_info()['workers']) == workers, timeout=120.0)

    def _start(self, name: str, *args: str) -> None:
        log = open(self.logs / f'{name}.log', 'w')
        self.procs[name] = subprocess.Popen([dask_program(), *args], stdout=log, stderr=subprocess.STDOUT,
                                            start_new_session=True)

    def kill(self, name: str) -> None:
        os.killpg(self.procs[name].pid, signal.SIGKILL)
        self.procs[name].wait()

    def close(self) -> None:
        for proc in self.procs.values():
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGTERM)
        for proc in self.procs.values():
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()


@pytest.fixture
def cluster(tmp_path):
    c = Cluster(tmp_path)
    yield c
    c.close()


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
    assert {str(p.pid) for p in cluster.procs.values()} >= {w.split(':')[-1] for w in workers}


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
    assert str(cluster.procs['worker1'].pid) in {w.split(':')[-1] for w in table['worker']}
