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
    from bldc_plant_sim.core.plant import PlantCore
    from bldc_plant_sim.lockstep_loop import CHANNELS
    core = PlantCore({'inverter.topology': 6})
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


def test_the_first_clock_and_its_readers_wait_come_before_the_first_measurement():
    """The first /clock waits (up to FIRST_CLOCK_ACK_WAIT) for its readers' acknowledgements
    before measurement 0 goes out; later the ground truth goes out while the controller
    computes, and the sample before the hold step is marked hold_after."""
    from types import SimpleNamespace
    from bldc_plant_sim.lockstep_loop import LockstepLoop
    from bldc_plant_sim.plant_node import PlantNode
    events = []

    class Ticks(LockstepLoop):
        """The plant's tick with its real clock and state-once logic; publishers recorded."""
        _clock_due, _first_clock_due = PlantNode._clock_due, PlantNode._first_clock_due
        _publish_state_once, _publish_clock = PlantNode._publish_state_once, PlantNode._publish_clock

        def __init__(self) -> None:
            self.core = SimpleNamespace(step=0, time=0.0, advance=self._advance)
            self.schedule = SimpleNamespace(clock_ticks=2, state_ticks=1, is_due=lambda kind, k: True,
                                            holds_after=lambda kind, k, hold: k + 1 >= hold)
            self._clock_pub = SimpleNamespace(
                publish=lambda msg: events.append(('clock', self.core.step)),
                wait_for_all_acked=lambda timeout: events.append(('clock readers waited', self.core.step)) or True)
            self._channels = {ControllerKind.GATE: SimpleNamespace(
                kind=ControllerKind.GATE, wire=SimpleNamespace(encode=lambda sample, *_: sample),
                spec=SimpleNamespace(sample_of=lambda core: SimpleNamespace()),
                send=lambda sample: events.append(('measurement', self.core.step, sample.hold_after)))}
            self.parameters = {'command_timeout': 1.0}
            self._clock_acked, self._state_sent_step = False, -1
            self._target_step = 3

        def _advance(self) -> None:
            self.core.step += 1

        def _publish_state(self) -> None:
            events.append(('state', self.core.step))
            self._publish_clock()

        def _serve(self, channel, k, deadline) -> None:
            events.append(('command', k))

    ticks = Ticks()
    for _ in range(3):
        ticks._tick()
    assert events == [('state', 0), ('clock', 0), ('clock readers waited', 0), ('measurement', 0, False),
                      ('command', 0),
                      # later: the ground truth goes out while the controller computes
                      ('measurement', 1, False), ('state', 1), ('command', 1),
                      ('measurement', 2, True), ('state', 2), ('clock', 2), ('command', 2)]
