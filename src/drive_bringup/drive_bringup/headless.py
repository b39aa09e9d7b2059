"""Headless runner: a scenario's cores stepped in one process (no ROS).

The same PlantCore, DtcCore (or the scenario's own controller core,
``nodes.controller.core``) and PfcCore the nodes wrap, built from the same
validated parameter snapshots, stepped by the plant's lockstep
co-simulation (:mod:`bldc_plant_sim.core.cosim`) with each event applied at
its exact sim time. For sweeps, long reproduction runs and fast tests; a
system test shows it gives the same trajectory as the ROS graph.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bldc_plant_sim.core.cosim import CoSimulation, Trajectory
from bldc_plant_sim.core.plant import PlantCore
from bldc_plant_sim.core.lockstep import ticks_of
from drive_bringup.fused import FusedDtcLoop
from drive_bringup.scenario import Scenario

ON_TICK_EVERY = 4096   # base ticks between on_tick calls (about 0.1 s of sim time at 40 kHz)


def build_controllers(scenario: Scenario):
    """(drive controller core or None, pfc core or None) from the scenario's snapshots."""
    dtc = pfc = None
    if scenario.controller is not None:
        from drive_common.controller_api import CheckedCore   # a malformed command stops the run
        dtc = CheckedCore(scenario.controller.core_class()(scenario.node_parameters['controller']),
                          report=lambda text: None)
    if 'dtc_controller' in scenario.node_parameters:
        from dtc_controller.core.controller import DtcCore
        dtc = DtcCore(scenario.node_parameters['dtc_controller'])
    if 'pfc_controller' in scenario.node_parameters:
        from pfc_controller.core.average_current_control import PfcCore
        pfc = PfcCore(scenario.node_parameters['pfc_controller'])
    return dtc, pfc


@dataclass
class HeadlessResult:
    """A headless run; final_time, final_step, wall_time and samples_per_second as a graph run's RunResult."""

    scenario: Scenario
    trajectory: Trajectory
    final_time: float = 0.0      # s sim
    final_step: int = 0          # plant base ticks
    wall_time: float = 0.0       # s
    setup_time: float = 0.0      # s of wall_time spent building the cores
    bag = None                   # nothing recorded: the arrays are the run's data

    @property
    def samples_per_second(self) -> float:
        return self.final_step / self.wall_time if self.wall_time > 0 else 0.0

    @property
    def end_state(self) -> str:
        return self.trajectory.end_state

    @property
    def fault_kinds(self) -> tuple:
        return self.trajectory.fault_kinds

    def arrays(self) -> dict[str, np.ndarray]:
        """Plant ground truth as 'plant/state.<field>' and DTC/PFC status as 'dtc/status.<field>'
        (each status with the 'time' of the sample it answered, as its header stamp in a bag)."""
        out = {f'plant/state.{k}': v for k, v in self.trajectory.as_arrays().items()}
        for which in ('dtc', 'pfc'):
            out.update((f'{which}/status.{k}', v) for k, v in self.trajectory.status_arrays(which).items())
        return out

    def save(self, path: Path, arrays: dict[str, np.ndarray] | None = None) -> Path:
        """The arrays (default: :meth:`arrays`) as a compressed .npz at path."""
        np.savez_compressed(path, **(self.arrays() if arrays is None else arrays))
        return path


def run_headless(scenario: Scenario, record_every: int | None = None, on_tick=None,
                 fused: bool = True) -> HeadlessResult:
    """Run the scenario's cores for its duration, events at their exact times.

    on_tick: optional callable(cosim) before every ON_TICK_EVERY-th tick (a study's per-point
    deadline raises from it); the ticks between run in compiled chunks where the fused loop
    applies (:mod:`.fused`; fused=False: every tick per sample, same trajectory).
    """
    started = time.monotonic()
    snapshots = {k: dict(v) for k, v in scenario.node_parameters.items()}
    plant = PlantCore(dict(snapshots['plant'], pfc_enabled='pfc_controller' in snapshots))
    dtc, pfc = build_controllers(scenario)
    if record_every is None:
        p = plant.params
        period = p['state_period'] if p['state_period'] > 0 else p['dtc_period']
        record_every = ticks_of(period, plant.base_tick, 'state_period')
    cosim = CoSimulation(plant, dtc, pfc, record_every=record_every, on_tick=on_tick,
                         on_tick_every=ON_TICK_EVERY,
                         fused=FusedDtcLoop() if fused else None)
    setup_time = time.monotonic() - started
    cores = {'plant': plant, 'dtc_controller': dtc, 'controller': dtc, 'pfc_controller': pfc}
    for event in scenario.events:
        if event.time > plant.time:
            cosim.run(steps=plant.step_of(event.time) - plant.step)
        schema = scenario.schema(event.node)
        snapshots[event.node] = schema.validate_changes(snapshots[event.node], event.parameters)
        cores[event.node].reconfigure(snapshots[event.node])
    cosim.run(steps=plant.step_of(scenario.duration) - plant.step)
    return HeadlessResult(scenario, cosim.trajectory, final_time=plant.time, final_step=plant.step,
                          wall_time=time.monotonic() - started, setup_time=setup_time)
