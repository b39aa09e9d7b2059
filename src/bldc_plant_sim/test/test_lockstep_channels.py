"""The controller kinds: one table of lockstep topics, types and command conversion per kind."""
import math

from bldc_plant_sim.core.lockstep import ControllerKind, LockstepSchedule


class _Applied:
    def __init__(self) -> None:
        self.applied = []

    def apply_gates(self, switch_on):
        self.applied.append(('gate', tuple(switch_on)))

    def apply_duty(self, duty, enable):
        self.applied.append(('duty', (duty, enable)))


def test_every_kind_has_one_channel_whose_command_the_schedule_applies():
    from bldc_plant_sim.lockstep_loop import CHANNELS
    assert list(CHANNELS) == list(ControllerKind)
    commands = {ControllerKind.GATE: (True, False, False, True, False, False),
                ControllerKind.DUTY: (0.25, True)}
    for kind, spec in CHANNELS.items():
        msg = spec.command_type()
        if kind is ControllerKind.GATE:
            msg.switch_on = list(commands[kind])
        else:
            msg.duty, msg.enable = commands[kind]
        assert spec.command_sample.__name__.lower().startswith(kind.value)
        plant = _Applied()
        LockstepSchedule(1, 1, 1, False).latch(plant, kind, spec.command_of(msg))
        assert plant.applied == [(kind.value, commands[kind])]
        assert spec.node in spec.controller and spec.command_topic in spec.controller


def test_invalid_commands_are_named_per_kind():
    from types import SimpleNamespace
    from bldc_plant_sim.lockstep_loop import CHANNELS
    core = SimpleNamespace(topology=6)
    gate, duty = CHANNELS[ControllerKind.GATE], CHANNELS[ControllerKind.DUTY]
    assert gate.invalid(SimpleNamespace(topology=6), core) is None
    assert '4-switch' in gate.invalid(SimpleNamespace(topology=4), core)
    assert duty.invalid(SimpleNamespace(duty=0.5), core) is None
    for bad in (-0.1, 1.5, math.nan):
        assert 'outside [0, 1]' in duty.invalid(SimpleNamespace(duty=bad), core)


def test_a_kind_is_its_string_and_the_schedule_knows_its_period():
    schedule = LockstepSchedule(2, 3, 1, False)
    assert ControllerKind('gate') is ControllerKind.GATE and ControllerKind.DUTY == 'duty'
    assert f'{ControllerKind.GATE}' == 'gate'
    assert [ControllerKind.GATE.ticks(schedule), ControllerKind.DUTY.ticks(schedule)] == [2, 3]
    assert [k for k in range(7) if schedule.is_due(ControllerKind.DUTY, k)] == [0, 3, 6]
    assert schedule.due(4) == (True, False)
