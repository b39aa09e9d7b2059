"""Headless lockstep co-simulation: PlantCore + controller cores by direct calls (no ROS).

Same schedule as the plant node (:class:`.lockstep.LockstepSchedule`): at tick k the plant
samples, each due controller answers ``update(sample) -> (command, status)`` (a
:class:`drive_common.samples.GateSample` or :class:`drive_common.samples.DutySample`), the
command is latched and the plant advances a tick. The :class:`Trajectory` holds per recorded
tick the ground truth and statuses, sample for sample as a recorded ROS run; a ``fused`` runner
(drive_bringup.fused) adds compiled stretches as :class:`RecordBlock` arrays.
"""
from __future__ import annotations

from dataclasses import fields
from operator import attrgetter
from typing import Any, Callable

import numpy as np

from .faults import run_end
from .lockstep import ControllerKind, LockstepSchedule, ticks_of
from .front_end_kernel import FV_PROT
from .plant import FRONT_END_FIELDS, PlantCore, PlantStateSample, front_extras, state_sample, sv_slots

_SV_SLOTS = sv_slots()


_LISTS = ('steps', 'times', 'states', 'dtc_status', 'pfc_status', 'commands')


class _Rows:
    """Records of the per-sample path: one object per field and record."""

    def __init__(self) -> None:
        for name in _LISTS:
            setattr(self, name, [])

    def __len__(self) -> int:
        return len(self.steps)

    def pop(self) -> None:
        for name in _LISTS:
            getattr(self, name).pop()

    def list_of(self, name: str) -> list:
        return getattr(self, name)

    def column(self, name: str) -> np.ndarray | None:
        return None

    def status_columns(self, which: str) -> dict | None:
        return None


class FrontRecords:
    """The front end's part of a RecordBlock: front_end_values rows (n, FV_SIZE), the PROTECTION_*
    bits outside the front end, [(first step, fault fields)] per boost trip, pfc_due per record,
    pfc_status(step, row) and duty(step, row) of a due record."""

    def __init__(self, values, protection, faults, pfc_due, pfc_status, duty) -> None:
        self.values, self.protection, self.faults, self.pfc_due = values, protection, faults, pfc_due
        self.pfc_status, self.duty = pfc_status, duty

    def _fault_fields(self, steps: list, extras: dict) -> list[dict]:
        """The fault fields of each record: the block's, then each change from its step on."""
        out, changes, current = [], iter(self.faults), extras
        change = next(changes, None)
        for k in steps:
            while change is not None and k >= change[0]:
                current, change = change[1], next(changes, None)
            out.append(current)
        return out

    def extras(self, steps: list, extras: dict) -> list[dict]:
        """PlantCore.state_extras() of each record."""
        base = self.protection
        faults = self._fault_fields(steps, extras) if self.faults else [{}] * len(steps)
        return [{**extras, **f, **front_extras(row), 'protection': base | int(row[FV_PROT])}
                for row, f in zip(self.values[:len(steps)].tolist(), faults)]

    def column(self, name: str, steps: np.ndarray, extras: dict) -> np.ndarray | None:
        n = len(steps)
        if name == 'protection':
            return (self.protection | self.values[:n, FV_PROT].astype(np.int64)).astype(float)
        if self.faults and name in extras and name.startswith(('fault_', 'first_fault_')):
            return np.array([f[name] for f in self._fault_fields(steps.tolist(), extras)], dtype=float)
        slot = _FRONT_SLOTS.get(name)
        return None if slot is None else self.values[:n, slot].copy()


_FRONT_SLOTS = {name: slot for name, slot, _ in FRONT_END_FIELDS}


def _built_if_due(steps: list, due: np.ndarray, build) -> list:
    """build(step, row) of each due record, None for the others."""
    return [build(k, r) if d else None for r, (k, d) in enumerate(zip(steps, due[:len(steps)].tolist()))]


class RecordBlock:
    """Records of compiled ticks as arrays; objects are built only when asked for.

    sv: (n, SV_SIZE) state_values rows; applied: switches per record; extras: the block's
    state_extras(); due: DTC due per record; status / gate(step, row): its DtcStatusSample /
    GateSample; columns(steps, rows): due statuses as columns ({}: none; None: build objects).
    """

    def __init__(self, steps, base_tick, sv, applied, extras, due, status, gate, columns=None,
                 front=None) -> None:
        self.steps_, self.base_tick, self.sv, self.applied = steps, base_tick, sv, applied
        self.extras, self.due, self.status, self.gate = extras, due, status, gate
        self.columns, self.front = columns, front
        self.n = len(steps)

    def __len__(self) -> int:
        return self.n

    def pop(self) -> None:
        self.n -= 1

    def list_of(self, name: str) -> list:
        """One of the Trajectory lists (_LISTS) over this block's records."""
        n, front = self.n, self.front
        steps = self.steps_[:n].tolist()
        if name == 'steps':
            return steps
        if name == 'times':
            return [k * self.base_tick for k in steps]
        if name == 'states':
            extras = front.extras(steps, self.extras) if front is not None else [self.extras] * n
            return [state_sample(k, v, a, x)
                    for k, v, a, x in zip(steps, self.sv[:n].tolist(), self.applied, extras)]
        if name == 'pfc_status':
            return _built_if_due(steps, front.pfc_due, front.pfc_status) if front is not None else [None] * n
        seq = _built_if_due(steps, self.due, self.status if name == 'dtc_status' else self.gate)
        if name == 'dtc_status':
            return seq
        duties = _built_if_due(steps, front.pfc_due, front.duty) if front is not None else [None] * n
        return list(zip(seq, duties))

    def status_columns(self, which: str) -> dict | None:
        """The 'dtc' / 'pfc' statuses as 'time' and field columns ({}: none; None: not held so)."""
        if which == 'pfc':
            return {} if self.front is None else None
        if self.columns is None:
            return None
        rows = np.flatnonzero(self.due[:self.n])
        steps = self.steps_[rows]
        columns = self.columns(steps, rows) if len(rows) else {}
        return {'time': steps * self.base_tick, **columns} if columns else {}

    def column(self, name: str) -> np.ndarray | None:
        """One PlantState field as a float array without building objects (None: not held here)."""
        n = self.n
        if name == 'step':
            return self.steps_[:n].astype(float)
        if name == 'applied_switch_on':
            return np.array(self.applied[:n], dtype=float).reshape(n, -1)
        slot = _SV_SLOTS.get(name)
        if isinstance(slot, tuple):
            return self.sv[:n, slot[0]:slot[0] + slot[1]].copy()
        if slot is not None:
            return self.sv[:n, slot].copy()
        if self.front is not None:
            col = self.front.column(name, self.steps_[:n], self.extras)
            if col is not None:
                return col
        value = np.asarray(self.extras[name], dtype=float)
        return np.broadcast_to(value, (n, *value.shape)).copy()


class Trajectory:
    """Per-sample records of a headless run (parts: per-sample rows and compiled blocks).

    Lists built on first use: steps, times, states, dtc_status / pfc_status (None if not due),
    commands ((gate, duty)); end_state and fault_kinds say how the run ended.
    """

    def __init__(self) -> None:
        self._parts: list = []
        self._lists: dict[str, list] = {}   # built on first use, cleared on a change
        self.end_state = 'ended normally'
        self.fault_kinds: tuple = ()

    def __len__(self) -> int:
        return sum(len(p) for p in self._parts)

    def _rows(self) -> _Rows:
        """The part per-sample records go to."""
        if not self._parts or not isinstance(self._parts[-1], _Rows):
            self._parts.append(_Rows())
        self._lists.clear()
        return self._parts[-1]

    def add_block(self, block: RecordBlock) -> None:
        if len(block):
            self._parts.append(block)
            self._lists.clear()

    def pop_last_if(self, step: int) -> None:
        """Drop the last record if it is of tick step (the final record of a previous run())."""
        parts = [p for p in self._parts if len(p)]
        if parts and self._last_step(parts[-1]) == step:
            parts[-1].pop()
            self._lists.clear()

    @staticmethod
    def _last_step(part) -> int:
        return part.steps[-1] if isinstance(part, _Rows) else int(part.steps_[part.n - 1])

    def _get(self, name: str) -> list:
        if name not in self._lists:
            self._lists[name] = [x for part in self._parts for x in part.list_of(name)[:len(part)]]
        return self._lists[name]

    steps = property(lambda self: self._get('steps'))
    times = property(lambda self: self._get('times'))
    states = property(lambda self: self._get('states'))
    dtc_status = property(lambda self: self._get('dtc_status'))
    pfc_status = property(lambda self: self._get('pfc_status'))
    commands = property(lambda self: self._get('commands'))

    def array(self, name: str) -> np.ndarray:
        """numpy array of one PlantState field over the records (tuples become columns)."""
        cols = []
        for part in (p for p in self._parts if len(p)):
            col = part.column(name)
            if col is None:
                col = np.array([getattr(s, name) for s in part.list_of('states')[:len(part)]], dtype=float)
            cols.append(col)
        return np.concatenate(cols) if cols else np.array([], dtype=float)

    def status_arrays(self, which: str) -> dict[str, np.ndarray]:
        """The 'dtc' / 'pfc' statuses as 'time' and numeric field arrays ({} without any)."""
        pieces = []
        for part in (p for p in self._parts if len(p)):
            columns = part.status_columns(which)
            if columns is None:
                seq = part.list_of(f'{which}_status')[:len(part)]
                columns = _object_columns(part.list_of('times')[:len(part)], seq)
            if columns:
                pieces.append(columns)
        return {k: np.concatenate([p[k] for p in pieces]) for k in pieces[0]
                if all(k in p for p in pieces)} if pieces else {}

    def as_arrays(self) -> dict[str, np.ndarray]:
        """Every PlantState field as an array, plus 'step' and 'time'."""
        times = [np.array(p.times[:len(p)]) if isinstance(p, _Rows) else p.steps_[:p.n] * p.base_tick
                 for p in self._parts if len(p)]
        out = {'step': None, 'time': np.concatenate(times) if times else np.array([])}
        for f in fields(PlantStateSample):
            out[f.name] = self.array(f.name)
        return out


def _object_columns(times: list, seq: list) -> dict[str, np.ndarray]:
    """Status objects (None: none at that record) as 'time' and numeric field arrays."""
    statuses = [s for s in seq if s is not None]
    if not statuses:
        return {}
    out = {'time': np.array([t for t, s in zip(times, seq) if s is not None], dtype=float)}
    names = [f.name for f in fields(statuses[0])]
    for name, column in zip(names, zip(*map(attrgetter(*names), statuses))):
        try:
            out[name] = np.array(column, dtype=float)
        except (TypeError, ValueError):
            continue
    return out


class CoSimulation:
    """Steps a PlantCore with controller cores under the lockstep semantics.

    dtc / pfc: ``update(sample) -> (command, status)`` or None; periods [s] default to the
    plant's; record_every: ticks between records (0: never); on_tick(cosim): run before every
    on_tick_every-th tick; fused: ``fused.chunk(cosim, steps) -> ticks done`` (0: per sample).
    """

    def __init__(self, plant: PlantCore, dtc=None, pfc=None, *, dtc_period: float | None = None,
                 pfc_period: float | None = None, computation_delay: bool | None = None,
                 record_every: int = 1, on_tick: Callable[['CoSimulation'], Any] | None = None,
                 on_tick_every: int = 1, fused=None) -> None:
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
        self.on_tick_every = max(1, int(on_tick_every))
        self.fused = fused
        self.trajectory = Trajectory()
        self._counts_start = list(plant.faults.counts)

    def _record(self, dtc_status, pfc_status, commands) -> None:
        plant = self.plant
        self.trajectory.pop_last_if(plant.step)   # final record of a previous run()
        tr = self.trajectory._rows()
        tr.steps.append(plant.step)
        tr.times.append(plant.time)
        tr.states.append(plant.state())
        tr.dtc_status.append(dtc_status)
        tr.pfc_status.append(pfc_status)
        tr.commands.append(commands)

    def tick(self) -> None:
        """One base tick: sample, ask due controllers, latch, advance."""
        if self.on_tick is not None:
            self.on_tick(self)
        self._tick_body()

    def _tick_body(self) -> None:
        plant = self.plant
        sched = self.schedule
        k = plant.step
        dtc_due, pfc_due = sched.due(k)
        dtc_status = pfc_status = gate = duty = None
        if dtc_due:
            gate, dtc_status = self.dtc.update(plant.drive_sample())
            if gate.step != k:
                raise RuntimeError(f'DTC core answered step {gate.step} for step {k}')
            wrong = plant.wrong_topology(gate.topology)
            if wrong is not None:
                raise RuntimeError(wrong)
            sched.latch(plant, ControllerKind.GATE, gate.switch_on)
        if pfc_due:
            sample = plant.pfc_sample()
            if sample is not None:
                duty, pfc_status = self.pfc.update(sample)
                sched.latch(plant, ControllerKind.DUTY, (duty.duty, duty.enable))
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
        if self.fused is None:
            for _ in range(int(steps)):
                self.tick()
        else:
            self._run_fused(int(steps))
        if self.record_every:
            self._record(None, None, (None, None))
        self._judge_end()
        return self.trajectory

    def _run_fused(self, steps: int) -> None:
        """steps ticks in compiled chunks where the runner applies (on_tick as in tick())."""
        done = 0
        hook, every = self.on_tick, self.on_tick_every
        while done < steps:
            k = self.plant.step
            if hook is not None and (every == 1 or k % every == 0):
                hook(self)
            n = steps - done if hook is None or every == 1 else min(steps - done, every - k % every)
            ran = self.fused.chunk(self, n) if every > 1 or hook is None else 0
            if ran == 0:
                self._tick_body()
                ran = 1
            done += ran

    def _judge_end(self) -> None:
        """The trajectory's end state, as the plant node says it for a run."""
        self.plant.faults.drain()           # nobody reports them here; the counters keep them
        end = run_end(self.plant, self._counts_start)
        self.trajectory.end_state, self.trajectory.fault_kinds = end.end_state, end.fault_kinds


def run_headless(params: dict, dtc=None, pfc=None, duration: float = 0.01, **kwargs) -> Trajectory:
    """Build a PlantCore from params and run it with the given controllers for duration [s]."""
    return CoSimulation(PlantCore(params), dtc, pfc, **kwargs).run(duration)
