"""Lockstep schedule shared by the plant node and the headless co-simulation.

docs/architecture.md "Time and lockstep": a controller with period N base ticks is due at tick
k when k % N == 0; its command is latched at the sample it answers (with ``computation_delay``
one controller sample later, as a DSP) and held until the next. With that delay the node may
pipeline (:meth:`LockstepSchedule.hold` / :meth:`LockstepSchedule.apply_held`).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from enum import StrEnum

from drive_common.parameters import ParameterError
from drive_common.samples import ALL_OFF


class ControllerKind(StrEnum):
    """A lockstep controller: what it commands, its period and how its command is applied
    (lockstep_loop.CHANNELS adds the topics). A StrEnum: ``ControllerKind.GATE == 'gate'``."""

    GATE = 'gate'    # dtc_controller: switch_on (bool[6])
    DUTY = 'duty'    # pfc_controller: (duty, enable)

    @property
    def initial(self) -> tuple:
        """The command held before any: all switches off, or duty 0 disabled."""
        return ALL_OFF if self is ControllerKind.GATE else (0.0, False)

    def ticks(self, schedule: 'LockstepSchedule') -> int:
        """The controller's period in base ticks (0: not in the run)."""
        return schedule.dtc_ticks if self is ControllerKind.GATE else schedule.pfc_ticks

    def apply(self, plant, command: tuple) -> None:
        """plant.apply_gates(switch_on) or plant.apply_duty(duty, enable)."""
        if self is ControllerKind.GATE:
            plant.apply_gates(command)
        else:
            plant.apply_duty(*command)


def ticks_of(period: float, base_tick: float, what: str) -> int:
    """Integer number of base ticks in period (0 if period <= 0); raises ParameterError (a
    ValueError) if it is not a multiple."""
    if period <= 0.0:
        return 0
    n = round(period / base_tick)
    if n < 1 or abs(n * base_tick - period) > 1e-9 * period + 1e-15:
        raise ParameterError(f'{what}: {period} s is not an integer multiple of base_tick {base_tick} s')
    return n


@dataclass
class LockstepSchedule:
    """Which controllers are due at tick k (periods in base ticks, 0 = not used), and how their
    commands are latched; ground truth every state_ticks ticks."""

    dtc_ticks: int
    pfc_ticks: int
    state_ticks: int
    computation_delay: bool
    clock_ticks: int = 0          # /clock every this many ticks (0 = with every state)
    _held: dict = field(default_factory=lambda: {kind: kind.initial for kind in ControllerKind},
                        repr=False)

    @classmethod
    def from_params(cls, params: dict, base_tick: float) -> 'LockstepSchedule':
        dtc = ticks_of(params['dtc_period'], base_tick, 'dtc_period')
        pfc = ticks_of(params['pfc_period'], base_tick, 'pfc_period') if params['pfc_enabled'] else 0
        state = max(1, ticks_of(params['state_period'], base_tick, 'state_period')
                    if params['state_period'] > 0 else (dtc or pfc or 1))
        # /clock goes out with a state sample: a whole number of state periods.
        clock = (max(1, round(params['clock_period'] / base_tick / state)) * state
                 if params['clock_period'] > 0 else 0)
        return cls(dtc, pfc, state, bool(params['computation_delay']), clock)

    def updated(self, params: dict, base_tick: float) -> 'LockstepSchedule':
        """A schedule for new parameters that keeps the commands held so far."""
        new = self.from_params(params, base_tick)
        return replace(new, _held=dict(self._held))

    def is_due(self, kind: ControllerKind, step: int) -> bool:
        """The controller of this kind is due at tick step."""
        ticks = ControllerKind(kind).ticks(self)
        return ticks > 0 and step % ticks == 0

    def holds_after(self, kind: ControllerKind, step: int, hold_step: int) -> bool:
        """The sample of a controller due at step is its last before sim time holds at hold_step."""
        return step + ControllerKind(kind).ticks(self) >= hold_step

    def due(self, step: int) -> tuple[bool, bool]:
        """(DTC due, PFC due) at tick step."""
        return self.is_due(ControllerKind.GATE, step), self.is_due(ControllerKind.DUTY, step)

    def latch(self, plant, which: ControllerKind, command: tuple) -> None:
        """Apply a controller's command (with computation_delay: the one held, holding this one)."""
        kind = ControllerKind(which)
        if self.computation_delay:
            command, self._held[kind] = self._held[kind], command
        kind.apply(plant, command)

    # Pipelined (computation_delay): hold the late command, then apply what is held; latch()
    # does the same two steps in the other order, so both apply the same sequence.
    def hold(self, which: ControllerKind, command: tuple) -> None:
        """Keep the command of the previous due sample, received late (it acts from now on)."""
        self._held[ControllerKind(which)] = command

    def apply_held(self, plant, which: ControllerKind) -> None:
        """Apply the held command (the initial one, all off / duty 0, before any command)."""
        kind = ControllerKind(which)
        kind.apply(plant, self._held[kind])
