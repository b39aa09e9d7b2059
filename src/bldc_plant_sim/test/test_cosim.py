"""Headless lockstep loop: schedule, latching, computation delay; cores import no ROS."""
from __future__ import annotations

import subprocess
import sys

import numpy as np

from bldc_plant_sim.core.cosim import CoSimulation
from bldc_plant_sim.core.plant import PlantCore, PlantStateSample
from drive_common.samples import GateSample
from plant_test_helpers import bldc_params

ON = (True, False, False, True, False, False)
OFF = (False,) * 6


class Recorder:
    """Answers ON at its first call and OFF afterwards; remembers the steps it saw."""

    def __init__(self):
        self.steps = []

    def update(self, sample):
        self.steps.append(sample.step)
        return GateSample(sample.step, 6, ON if len(self.steps) == 1 else OFF), {'step': sample.step}


def test_controller_called_every_n_ticks_and_command_latched_between():
    plant = PlantCore(bldc_params(**{'base_tick': 12.5e-6, 'integration.max_step': 12.5e-6}))
    ctrl = Recorder()
    traj = CoSimulation(plant, ctrl, dtc_period=25e-6).run(steps=8)
    assert ctrl.steps == [0, 2, 4, 6]
    applied = [s.applied_switch_on for s in traj.states]
    # state k reports what was applied over [t_(k-1), t_k): ON held over ticks 0 and 1
    assert applied[1] == ON and applied[2] == ON and applied[3] == OFF
    assert traj.dtc_status[0] == {'step': 0} and traj.dtc_status[1] is None


def test_computation_delay_applies_each_command_one_controller_sample_late():
    plant = PlantCore(bldc_params())
    traj = CoSimulation(plant, Recorder(), computation_delay=True).run(steps=4)
    applied = [s.applied_switch_on for s in traj.states]
    assert applied[1] == OFF and applied[2] == ON and applied[3] == OFF


def test_state_sample_fields_equal_the_plant_state_message():
    from pathlib import Path
    msg = Path(__file__).resolve().parents[2] / 'dtc_msgs' / 'msg' / 'PlantState.msg'
    names = []
    for line in msg.read_text().splitlines():
        line = line.split('#')[0].strip()
        if not line or '=' in line:
            continue
        names.append(line.split()[1])
    names.remove('header')
    assert list(PlantStateSample.__dataclass_fields__) == names
    s = PlantCore(bldc_params()).state()
    assert np.isnan(s.grid_voltage) and np.isnan(s.inductor_current)


def test_same_scenario_gives_identical_trajectories():
    def run():
        plant = PlantCore(bldc_params(**{'sensors.current_noise': 0.1}))
        return CoSimulation(plant, Recorder()).run(steps=50).as_arrays()
    a, b = run(), run()
    for key in a:
        np.testing.assert_array_equal(a[key], b[key])


def test_core_modules_import_no_ros():
    code = ('import sys, bldc_plant_sim.core.plant, bldc_plant_sim.core.cosim, '
            'bldc_plant_sim.backemf_generator, bldc_plant_sim.parameters; '
            "bad = [m for m in sys.modules if m.startswith('rclpy') or m.endswith('_msgs')]; "
            'assert not bad, bad')
    subprocess.run([sys.executable, '-c', code], check=True)
