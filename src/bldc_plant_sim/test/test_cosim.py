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


class _AppliedCommands:
    """Stands in for PlantCore: records every command applied to it."""

    def __init__(self):
        self.applied = []

    def apply_gates(self, switch_on):
        self.applied.append(('gate', switch_on))

    def apply_duty(self, duty, enable):
        self.applied.append(('duty', (duty, enable)))


def test_pipelined_hold_then_apply_gives_the_sequential_delayed_commands():
    """The plant node's pipelined order (LockstepSchedule.hold of the previous
    due sample's command, then apply_held) applies the same commands at the same
    due samples as latch() with computation_delay, across a drained hold."""
    from bldc_plant_sim.core.lockstep import LockstepSchedule
    commands = [('gate', ON if k % 3 else OFF) if k % 2 else ('duty', (0.1 * k, k % 4 != 1))
                for k in range(12)]
    sequential, plant = LockstepSchedule(1, 1, 1, True), _AppliedCommands()
    for which, command in commands:
        sequential.latch(plant, which, command)
    pipelined, piped = LockstepSchedule(1, 1, 1, True), _AppliedCommands()
    pending = {}
    for k, (which, command) in enumerate(commands):
        if which in pending:                       # received while the plant integrated
            pipelined.hold(which, pending.pop(which))
        pipelined.apply_held(piped, which)
        pending[which] = command
        if k == 6:                                 # end of a goal: drain, then resume
            for name, late in pending.items():
                pipelined.hold(name, late)
            pending.clear()
    assert piped.applied == plant.applied
    assert plant.applied[:2] == [('duty', (0.0, False)), ('gate', OFF)]   # nothing before a command


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
