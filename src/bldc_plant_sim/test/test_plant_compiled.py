"""The compiled plant kernels (core/plant_kernel.py, inverter, link, shaft) give bit-identical
trajectories to the same code interpreted (NUMBA_DISABLE_JIT=1): every shipped scenario on a
short run, and plant cases for the paths the scenarios do not reach on short runs (dead time,
a peak-current trip, the four-switch split link, a current-fed link, inner steps)."""
from pathlib import Path

import numpy as np

from bldc_plant_sim.core.cosim import CoSimulation
from bldc_plant_sim.core.plant import PlantCore
from bldc_plant_sim.core.plant_kernel import advance_tick
from drive_common.compiled import jit_disabled
from drive_testing.compiled_parity import differing, interpreted_and_compiled, requires_jit
from plant_test_helpers import SixStepChopper, bldc_params

pytestmark = requires_jit()

SCENARIOS = sorted(p.stem for p in (Path(__file__).resolve().parents[2] / 'drive_bringup'
                                    / 'scenarios').glob('*.yaml'))
CHOP = {'load.mode': 'viscous', 'load.viscous': 0.004}
CASES = {
    'dead_time_trip': {**CHOP, 'inverter.v_ce': 1.0, 'inverter.v_d': 0.8, 'inverter.r_on': 0.05,
                       'inverter.dead_time': 2e-6, 'protection.peak_current': 12.0,
                       'integration.max_step': 10e-6},
    'four_switch_split': {**CHOP, 'inverter.topology': 4, 'dc_link.mode': 'split_capacitors',
                          'protection.peak_current': 0.0},
    'current_fed': {**CHOP, 'dc_link.mode': 'current_fed', 'dc_link.source_current': 0.5,
                    'protection.peak_current': 0.0, 'inverter.v_ce': 1.0, 'inverter.v_d': 0.8},
}


def plant_runs(steps: int) -> dict:
    """State arrays and located events of each case after `steps` ticks of a six-step chopper."""
    out = {}
    for name, overrides in CASES.items():
        plant = PlantCore(bldc_params(base_tick=25e-6, dtc_period=25e-6, **overrides))
        ctrl = SixStepChopper(plant.motor.backemf, 3, 4, topology=plant.topology)
        arrays = CoSimulation(plant, ctrl).run(steps=steps).as_arrays()
        out.update({f'{name}:{k}': np.asarray(v, dtype=float) for k, v in arrays.items()})
        out[f'{name}:events'] = np.array([t for t, _ in plant.events])
        out[f'{name}:event_kinds'] = np.array([('zero' in what, 'trip' in what, 'limit' in what,
                                                'abc'.find(what[-1])) for _, what in plant.events], float)
    return out


def test_kernels_are_compiled():
    assert not jit_disabled() and hasattr(advance_tick, 'py_func')


def test_plant_cases_compiled_equal_interpreted(tmp_path):
    interpreted, compiled = interpreted_and_compiled('test_plant_compiled:plant_runs', [4000], tmp_path)
    assert compiled['dead_time_trip:protection'].max() > 0          # the trip was reached
    assert compiled['current_fed:events'].size > 0 and compiled['four_switch_split:events'].size > 0
    assert differing(interpreted, compiled) == []


def test_every_scenario_compiled_equals_interpreted(tmp_path):
    interpreted, compiled = interpreted_and_compiled('drive_testing.compiled_parity:scenario_arrays',
                                                     [SCENARIOS, 0.02], tmp_path)
    assert len({k.split(':')[0] for k in compiled}) == len(SCENARIOS) >= 22
    assert differing(interpreted, compiled) == []
