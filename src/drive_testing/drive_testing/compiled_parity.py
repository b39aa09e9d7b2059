"""Compiled vs interpreted kernels: the same run in this process and with ``NUMBA_DISABLE_JIT=1``.

:func:`interpreted_and_compiled` calls ``module:name(*args)``, returning a dict of numpy arrays,
here (kernels compiled by numba) and in a subprocess with the JIT disabled; tests compare the
arrays bit for bit with :func:`differing`.
"""
from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

_RUN = '''
import importlib, json, sys
import numpy as np
module, name = sys.argv[1].split(':')
np.savez(sys.argv[3], **getattr(importlib.import_module(module), name)(*json.loads(sys.argv[2])))
'''


def requires_jit():
    """pytest mark: skip when NUMBA_DISABLE_JIT=1 is set (nothing compiled to compare)."""
    import pytest
    return pytest.mark.skipif(os.environ.get('NUMBA_DISABLE_JIT', '0') not in ('', '0'),
                              reason='NUMBA_DISABLE_JIT is set: nothing compiled to compare')


def interpreted_and_compiled(target: str, args: list, tmp: Path):
    """(interpreted, compiled) dicts of arrays of ``module:function(*args)`` (args: JSON values)."""
    from drive_common.compiled import jit_disabled
    if jit_disabled():
        raise RuntimeError('the compiled run needs numba with the JIT enabled (NUMBA_DISABLE_JIT unset)')
    out = tmp / 'interpreted.npz'
    subprocess.run([sys.executable, '-c', _RUN, target, json.dumps(args), str(out)],
                   env=dict(os.environ, NUMBA_DISABLE_JIT='1', PYTHONPATH=os.pathsep.join(sys.path)),
                   check=True, timeout=900)
    with np.load(out) as data:
        interpreted = {k: data[k] for k in data.files}
    module, name = target.split(':')
    return interpreted, getattr(importlib.import_module(module), name)(*args)


def scenario_arrays(names: list, duration: float) -> dict:
    """Headless trajectory arrays of shipped scenarios, each shortened to duration [s]: 'name:key'."""
    from drive_bringup.headless import run_headless
    from drive_bringup.scenario import load_scenario
    from drive_common.uris import resolve_path
    out = {}
    for name in names:
        scenario = load_scenario(resolve_path(f'package://drive_bringup/scenarios/{name}.yaml'))
        arrays = run_headless(scenario.shortened(min(duration, scenario.duration))).arrays()
        out.update({f'{name}:{k}': v for k, v in arrays.items()})
    return out


def differing(a: dict, b: dict) -> list[str]:
    """Keys whose arrays are not bit-identical (NaN equal to NaN), or present in one only."""
    return sorted(k for k in a.keys() | b.keys()
                  if k not in a or k not in b or not np.array_equal(a[k], b[k], equal_nan=True))
