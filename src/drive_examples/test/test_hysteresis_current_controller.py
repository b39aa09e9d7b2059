"""The worked example of docs/write_your_own_controller.md, closed loop.

The example scenario (T* = 0.3 -> 0.6 N m at 50 ms, the BLDC of 000 held at
30 rad/s) runs headless and through the ROS graph (``run_scenario --isolate``:
plant, the example node started with ``ros2 run`` semantics, recorder,
analysis). Both: the mean true torque follows T* within 10 % before and after
the step; the graph's recorded trajectory equals the headless one sample for
sample (the lockstep is deterministic), and its status is recorded like the DTC's.
"""
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from drive_bringup.headless import run_headless
from drive_bringup.scenario import find_scenario, load_scenario
from drive_common.samples import DriveSample
from drive_testing.compiled_parity import requires_jit
from drive_examples.hysteresis_current_controller import PAIRS, HysteresisCurrentCore

SCENARIO = 'example_hysteresis_current_control'
WINDOWS = ((0.01, 0.05, 0.3), (0.06, 0.1, 0.6))     # (t_start s, t_end s, T* N m)
TOLERANCE = 0.10                                    # relative, of T*


def _mean_torque(time, torque, t_start, t_end) -> float:
    mask = (time >= t_start) & (time < t_end)
    assert mask.sum() > 1000
    return float(torque[mask].mean())


def _sample(step, angle, currents):
    return DriveSample(step, 0.0, currents, 56.6, 28.3, 0, angle, 0, 30.0)


def test_core_drives_the_flat_top_pair_and_chops_with_hysteresis():
    core = HysteresisCurrentCore({'torque_reference': 0.2292, 'current_band': 0.1})   # I* = 1 A
    angle = math.radians(60.0)                          # sector 0: b driven +, a driven -
    plus, minus = PAIRS[0]
    low = [0.0, 0.0, 0.0]
    gate, status = core.update(_sample(7, angle, tuple(low)))
    assert gate.step == 7 and gate.topology == 6
    assert gate.switch_on == (False, True, True, False, False, False)   # b upper, a lower: +V
    high = [0.0] * 3
    high[plus], high[minus] = 1.2, -1.2                 # pair current 1.2 A > 1 + 0.1
    gate, status = core.update(_sample(8, angle, tuple(high)))
    assert gate.switch_on == (True, False, False, True, False, False)   # reversed: -V
    assert status.sector == 1 and status.torque_hysteresis == -1
    assert status.torque_estimate == pytest.approx(0.2292 * 1.2)
    assert math.isnan(status.flux_alpha)                # what it has no value for
    inside = [0.0] * 3
    inside[plus], inside[minus] = 1.0, -1.0             # within the band: holds -V
    assert core.update(_sample(9, angle, tuple(inside)))[0].switch_on == gate.switch_on


@pytest.fixture(scope='module')
def headless():
    result = run_headless(load_scenario(find_scenario(SCENARIO))).arrays()
    return result


def test_headless_torque_follows_the_reference(headless):
    for t_start, t_end, reference in WINDOWS:
        mean = _mean_torque(headless['plant/state.time'],
                            headless['plant/state.electromagnetic_torque'], t_start, t_end)
        assert abs(mean - reference) <= TOLERANCE * reference, (t_start, mean)
    assert np.all(headless['dtc/status.torque_reference'][-10:] == 0.6)


@pytest.mark.ros
def test_ros_graph_runs_records_analyses_and_equals_headless(headless, tmp_path):
    from drive_analysis.bag_columns import load_columns
    out = tmp_path / 'out'
    result = subprocess.run([sys.executable, '-m', 'drive_bringup.runner_cli', SCENARIO,
                             '--isolate', '--out', str(out)],
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'controller torque_reference = 0.6' in result.stdout
    report = json.loads((out / 'report.json').read_text())
    assert len(report['checks']) == 2 and all(row['pass'] for row in report['checks']), report
    columns = load_columns(str(out / 'bag'))
    state, status = columns['/plant/state'], columns['/dtc/status']
    for t_start, t_end, reference in WINDOWS:
        mean = _mean_torque(state['t'], state['electromagnetic_torque'], t_start, t_end)
        assert abs(mean - reference) <= TOLERANCE * reference, (t_start, mean)
    assert np.array_equal(state['step'], headless['plant/state.step'])
    for name in ('phase_current', 'electromagnetic_torque', 'mechanical_speed', 'rotor_angle'):
        assert np.array_equal(state[name], headless[f'plant/state.{name}']), name
    assert set(status['mode'].tolist()) == {'hysteresis_current'}
    assert np.array_equal(status['torque_estimate'], headless['dtc/status.torque_estimate'])


@requires_jit()
def test_the_compiled_comparator_gives_the_interpreted_trajectory_bit_for_bit(tmp_path):
    """The worked case of compiling your own core: pair_current_step under numba and as plain
    Python (NUMBA_DISABLE_JIT=1) give the same closed-loop run."""
    from drive_examples.hysteresis_current_controller import pair_current_step
    from drive_testing.compiled_parity import differing, interpreted_and_compiled
    assert hasattr(pair_current_step, 'py_func')        # compiled in this process
    interpreted, compiled = interpreted_and_compiled('drive_testing.compiled_parity:scenario_arrays',
                                                     [[SCENARIO], 0.02], tmp_path)
    torque = compiled[f'{SCENARIO}:dtc/status.torque_estimate']
    assert torque.size > 100 and np.ptp(torque) > 0.0
    assert differing(interpreted, compiled) == []
