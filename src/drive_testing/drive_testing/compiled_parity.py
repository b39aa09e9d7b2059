"""Compiled vs interpreted kernels: the same scenario's headless trajectory both ways.

:func:`interpreted_and_compiled` runs a shipped scenario (shortened) with the
headless runner twice: in this process (kernels compiled by numba, see
:mod:`drive_common.compiled`) and in a subprocess with ``NUMBA_DISABLE_JIT=1``
(the same kernels as plain Python); tests compare the arrays bit for bit.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

_RUN = '''
import sys
import numpy as np
from drive_bringup.headless import run_headless
from drive_bringup.scenario import load_scenario
scenario = load_scenario(sys.argv[1])
np.savez(sys.argv[3], **run_headless(scenario.shortened(min(float(sys.argv[2]), scenario.duration))).arrays())
'''


def scenario_path(name: str) -> Path:
    """A shipped scenario file by name (src/drive_bringup/scenarios/<name>.yaml)."""
    from drive_common.uris import resolve_path
    return Path(resolve_path(f'package://drive_bringup/scenarios/{name}.yaml'))


def headless_arrays(name: str, duration: float, out: Path, disable_jit: bool) -> dict[str, np.ndarray]:
    """Trajectory arrays of scenario name over duration [s], run in a subprocess."""
    env = dict(os.environ, NUMBA_DISABLE_JIT='1' if disable_jit else '0')
    subprocess.run([sys.executable, '-c', _RUN, str(scenario_path(name)), repr(duration), str(out)],
                   env=env, check=True, timeout=600)
    with np.load(out) as data:
        return {k: data[k] for k in data.files}


def interpreted_and_compiled(name: str, duration: float, tmp: Path):
    """(interpreted, compiled) trajectory arrays of scenario name over duration [s]."""
    from drive_bringup.headless import run_headless
    from drive_bringup.scenario import load_scenario
    from drive_common.compiled import jit_disabled
    if jit_disabled():
        raise RuntimeError('the compiled run needs numba with the JIT enabled (NUMBA_DISABLE_JIT unset)')
    interpreted = headless_arrays(name, duration, tmp / f'{name}_interpreted.npz', disable_jit=True)
    scenario = load_scenario(scenario_path(name))
    compiled = run_headless(scenario.shortened(min(duration, scenario.duration))).arrays()
    return interpreted, compiled


def differing(a: dict, b: dict) -> list[str]:
    """Keys whose arrays are not bit-identical (NaN equal to NaN), or present in one only."""
    return sorted(k for k in a.keys() | b.keys()
                  if k not in a or k not in b or not np.array_equal(a[k], b[k], equal_nan=True))
