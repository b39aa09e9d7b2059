"""Headless lockstep co-simulation: PlantCore + controller cores by direct calls (no ROS).

Same schedule as the plant node (docs/architecture.md "Time and lockstep",
:class:`.lockstep.LockstepSchedule`): at base tick k the plant samples; each
controller due at k (k % N == 0) gets its sample and answers
``update(sample) -> (command, status)``; the command is latched (one
controller sample late with ``computation_delay``) and held until the next
one; the plant advances one tick. DTC commands are
:class:`drive_common.samples.GateSample`, PFC commands
:class:`drive_common.samples.DutySample`.

The result is a :class:`Trajectory`: per recorded tick the step, time, plant
ground truth (PlantStateSample) and the statuses the controllers returned at
that tick, comparable sample for sample with a recorded ROS run.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any, Callable

import numpy as np

from .lockstep import LockstepSchedule, ticks_of
from .plant import PlantCore, PlantStateSample


@dataclass
class Trajectory:
    """Per-sample records of a headless run."""

    steps: list = field(default_factory=list)
    times: list = field(default_factory=list)
    states: list = field(default_factory=list)        # PlantStateSample at t_k
    dtc_status: list = field(default_factory=list)    # status returned at t_k (None if not due)
    pfc_status: list = field(default_factory=list)
    commands: list = field(default_factory=list)      # (gate command, duty command) returned at t_k
    end_state: str = 'ended normally'                 # how the run ended (core/faults.py wording)
    fault_kinds: tuple = ()                           # fault kind labels recorded during the run

    def __len__(self) -> int:
        return len(self.steps)

    def array(self, name: str) -> np.ndarray:
        """numpy array of one PlantState field over the records (tuples become columns)."""
        return np.array([getattr(s, name) for s in self.states], dtype=float)

    def as_arrays(self) -> dict[str, np.ndarray]:
        """Every PlantState field as an array, plus 'step' and 'time'."""
        out = {'step': np.array(self.steps), 'time': np.array(self.times)}
        for f in fields(PlantStateSample):
            out[f.name] = self.array(f.name)
        return out


class CoSimulation:
    """Steps a PlantCore with controller cores under the lockstep semantics.

    dtc / pfc: objects with ``update(sample) -> (command, status)`` (or None).
    dtc_period / pfc_period: controller periods [s], integer multiples of the
        plant's base tick (default: the plant's dtc_period / pfc_period).
    computation_delay: apply each command one controller sample late.
    record_every: record plant state every this many ticks (0 = never).
    on_tick: optional callable(cosim) run before each tick (scripted events).
    """

    def __init__(self, plant: PlantCore, dtc=None, pfc=None, *, dtc_period: float | None = None,
                 pfc_period: float | None = None, computation_delay: bool | None = None,
                 record_every: int = 1, on_tick: Callable[['CoSimulation'], Any] | None = None) -> None:
        self.plant = plant
        self.dtc, self.pfc = dtc, pfc
        p = plant.params
        tick = plant.base_tick
        dtc_ticks = ticks_of(p['dtc_period'] if dtc_period is None else dtc_period, tick,
                             'dtc_period') if dtc is not None else 0
        pfc_ticks = ticks_of(p['pfc_period'] if pfc_period is None else pfc_period, tick,
                             'pfc_period') if pfc is not None else 0
        delay = p['computation_delay'] if computation_delay is None else computation_delay
        self.schedule = LockstepSchedule(dtc_ticks, pfc_ticks, 1, bool(delay))
        self.record_every = int(record_every)
        self.on_tick = on_tick
        self.trajectory = Trajectory()
        self._counts_start = list(plant.faults.counts)   # the trajectory's end state counts from here

    def _record(self, dtc_status, pfc_status, commands) -> None:
        plant = self.plant
        tr = self.trajectory
        if tr.steps and tr.steps[-1] == plant.step:   # final record of a previous run()
            for seq in (tr.steps, tr.times, tr.states, tr.dtc_status, tr.pfc_status, tr.commands):
                seq.pop()
        tr.steps.append(plant.step)
        tr.times.append(plant.time)
        tr.states.append(plant.state())
        tr.dtc_status.append(dtc_status)
        tr.pfc_status.append(pfc_status)
        tr.commands.append(commands)

    def tick(self) -> None:
        """One base tick: sample, ask due controllers, latch, advance."""
        plant = self.plant
        sched = self.schedule
        k = plant.step
        if self.on_tick is not None:
            self.on_tick(self)
        dtc_due, pfc_due = sched.due(k)
        dtc_status = pfc_status = gate = duty = None
        if dtc_due:
            gate, dtc_status = self.dtc.update(plant.drive_sample())
            if gate.step != k:
                raise RuntimeError(f'DTC core answered step {gate.step} for step {k}')
            if gate.topology != plant.topology:
                raise RuntimeError(f'gate command for a {gate.topology}-switch inverter, '
                                   f'the plant has {plant.topology}')
            sched.latch_gates(plant, gate.switch_on)
        if pfc_due:
            sample = plant.pfc_sample()
            if sample is not None:
                duty, pfc_status = self.pfc.update(sample)
                sched.latch_duty(plant, duty.duty, duty.enable)
        if self.record_every and k % self.record_every == 0:
            self._record(dtc_status, pfc_status, (gate, duty))
        plant.advance()

    def run(self, duration: float | None = None, steps: int | None = None) -> Trajectory:
        """Advance by duration [s] or a number of ticks; records the final state too."""
        plant = self.plant
        if steps is None:
            if duration is None:
                raise ValueError('give duration or steps')
            steps = plant.step_of(plant.time + duration) - plant.step
        tick = self.tick
        for _ in range(int(steps)):
            tick()
        if self.record_every:
            self._record(None, None, (None, None))
        self._judge_end()
        return self.trajectory

    def _judge_end(self) -> None:
        """The trajectory's end state, as the plant node says it for a run (same core record)."""
        plant, tr = self.plant, self.trajectory
        record = plant.faults
        record.drain()                      # nobody reports them here; the counters keep them
        before = self._counts_start
        tr.fault_kinds = record.kinds_since(before)
        tr.end_state = record.end_state(sum(before), bool(plant.protection) or plant.in_safe_state)


def run_headless(params: dict, dtc=None, pfc=None, duration: float = 0.01, **kwargs) -> Trajectory:
    """Build a PlantCore from params and run it with the given controllers for duration [s]."""
    return CoSimulation(PlantCore(params), dtc, pfc, **kwargs).run(duration)
