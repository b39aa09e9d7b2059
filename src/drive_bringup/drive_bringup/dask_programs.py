"""A Dask cluster of separate programs on this machine: `dask scheduler` + N `dask worker`.

For the cluster tests and the scale-out benchmark: each program runs in its
own process group on a free localhost port and is ended by its pid. The same
commands, run on other hosts against the scheduler's address, make a real
cluster (docs/studies.md).
"""
from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path


def free_port() -> int:
    """A TCP port free on localhost right now."""
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def dask_command() -> str:
    """The `dask` program of this Python environment (FileNotFoundError if absent)."""
    path = shutil.which('dask', path=str(Path(sys.executable).parent) + os.pathsep + os.environ['PATH'])
    if path is None:
        raise FileNotFoundError('no `dask` program: install the pinned dask/distributed (scripts/setup.sh)')
    return path


class DaskPrograms:
    """`dask scheduler` and ``workers`` single-threaded `dask worker` processes (no nanny)."""

    def __init__(self, log_dir: Path, workers: int = 2, start_timeout: float = 120.0) -> None:
        self.port = free_port()
        self.address = f'tcp://127.0.0.1:{self.port}'
        self.log_dir = Path(log_dir)
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self.procs: dict[str, subprocess.Popen] = {}
        try:
            self._start('scheduler', 'scheduler', '--host', '127.0.0.1', '--port', str(self.port),
                        '--no-dashboard')
            for i in range(workers):
                self._start(f'worker{i}', 'worker', self.address, '--nworkers', '1', '--nthreads', '1',
                            '--no-nanny', '--no-dashboard', '--name', f'worker{i}',
                            '--local-directory', str(self.log_dir / f'worker{i}'))
            from distributed import Client
            with Client(self.address, timeout=f'{start_timeout}s') as client:
                client.wait_for_workers(workers, timeout=start_timeout)
        except BaseException:
            self.close()
            raise

    def _start(self, name: str, *args: str) -> None:
        with open(self.log_dir / f'{name}.log', 'w') as log:
            self.procs[name] = subprocess.Popen([dask_command(), *args], stdout=log,
                                                stderr=subprocess.STDOUT, start_new_session=True)

    def pid(self, name: str) -> int:
        return self.procs[name].pid

    def kill(self, name: str) -> None:
        """SIGKILL one program (e.g. a worker dying mid-study)."""
        os.killpg(self.procs[name].pid, signal.SIGKILL)
        self.procs[name].wait()

    def close(self, timeout: float = 20.0) -> None:
        """SIGTERM the workers, then the scheduler; SIGKILL what is still running after timeout [s].

        Workers go first: a worker whose scheduler closes under it starts its own close, and a
        SIGTERM arriving during that close leaves it hanging until the SIGKILL.
        """
        workers = [proc for name, proc in self.procs.items() if name != 'scheduler']
        self._terminate(workers, timeout)
        self._terminate([self.procs[name] for name in self.procs if name == 'scheduler'], timeout)

    @staticmethod
    def _terminate(procs: list[subprocess.Popen], timeout: float) -> None:
        for proc in procs:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGTERM)
        deadline = time.monotonic() + timeout
        for proc in procs:
            try:
                proc.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()

    def __enter__(self) -> 'DaskPrograms':
        return self

    def __exit__(self, *exc) -> None:
        self.close()
