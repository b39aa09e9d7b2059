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


# Three-phase DTC options the shipped scenarios do not use: (mode, parameters, with the
# synthetic back-EMF table); at half time each case turns rotation and drop compensation
# and widens the bands (runtime reconfiguration).
DTC_OPTION_CASES = [
    ('three_phase_pmsm', {}, True),
    ('three_phase_pmsm', {'three_phase.pm_flux': 0.05, 'estimation.encoder_offset': 0.3}, False),
    ('three_phase_pmsm', {'three_phase.integrator': 'low_pass', 'three_phase.low_pass_compensation': True,
                          'flux_control.reference_source': 'backemf_table', 'speed_loop.enabled': True,
                          'speed_reference': 30.0}, True),
    ('three_phase_pmsm', {'three_phase.flux_model': 'current', 'three_phase.pm_flux': 0.05}, False),
    ('three_phase_pmsm', {'three_phase.integrator': 'hu_wu', 'three_phase.position_source': 'sensorless',
                          'three_phase.initial_angle': 0.4, 'estimation.initial_flux': 'zero'}, True),
    ('three_phase_four_switch', {'voltage_drop.compensation': 'proposed',
                                 'three_phase.low_pass_compensation': True}, True),
    ('three_phase_dtifc', {'speed_loop.enabled': True, 'speed_reference': 20.0}, True),
    ('three_phase_dtifc', {'three_phase.position_source': 'encoder', 'dtifc.d_current_reference': -0.5}, True),
]


def dtc_option_arrays(samples: int) -> dict:
    """Status and gate arrays of DtcCore for :data:`DTC_OPTION_CASES` over synthetic measurements
    (rotating currents nudged by the applied gates, one current sensor missing now and then): 'case:field'."""
    import math
    from dataclasses import fields

    from drive_common.samples import DriveSample
    from dtc_controller.core.backemf_table import BackEmfTable
    from dtc_controller.core.controller import DtcCore
    from dtc_controller.core.status import DtcStatusSample

    th = np.arange(360) * (2 * np.pi / 360)
    table = BackEmfTable.from_phase_constants(
        *(0.0573 * np.clip(-np.sin(th - s) * 2.0, -1.0, 1.0) for s in (0, 2 * np.pi / 3, 4 * np.pi / 3)), 2)
    names = [f.name for f in fields(DtcStatusSample) if f.name not in ('mode', 'switch_on')]
    out = {}
    for n, (mode, extra, with_table) in enumerate(DTC_OPTION_CASES):
        core = DtcCore({'mode': mode, 'torque_reference': 0.5, 'motor.pole_pairs': 2, **extra},
                       table if with_table else None)
        rows, gates, nudge = [], [], 0.0
        for k in range(samples):
            if k == samples // 2:
                core.reconfigure({'rotation': -1, 'torque_band': 0.01, 'flux_band': 0.002,
                                  'voltage_drop.compensation': 'simple'})
            w = 2 * math.pi * 25.0 * k * 25e-6
            i = [3 * math.sin(w + nudge), 3 * math.sin(w - 2.1 + nudge)]
            i.append(-i[0] - i[1])
            if k % 97 == 5:
                i[k % 3] = math.nan
            sample = DriveSample(k, k * 25e-6, tuple(i), 56.57 + math.sin(w), 28.28, 0, (2 * w) % (2 * math.pi),
                                 0, 30.0 + math.cos(w))
            gate, status = core.update(sample)
            nudge += 0.002 * (sum(gate.switch_on[0::2]) - 1.5)
            rows.append([float(getattr(status, f)) for f in names])
            gates.append(gate.switch_on)
        data = np.array(rows)
        out.update({f'{n}:{f}': data[:, j] for j, f in enumerate(names)})
        out[f'{n}:switch_on'] = np.array(gates, dtype=np.int8)
    return out
