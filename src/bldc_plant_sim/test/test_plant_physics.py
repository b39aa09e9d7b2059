"""Physics of PlantCore against analytic results, located events and energy balance."""
from __future__ import annotations

import math

import numpy as np
import pytest

from bldc_plant_sim.core.cosim import CoSimulation
from bldc_plant_sim.core.faults import PENDING_MAX, FaultKind, FaultRecord, fault_kind
from bldc_plant_sim.core.plant import PlantCore
from bldc_plant_sim.parameters import plant_params
from drive_common.samples import ALL_OFF
from plant_test_helpers import ScriptedGates, SixStepChopper, bldc_params

A_PLUS_B_MINUS = (True, False, False, True, False, False)


def _switching_run(max_step: float, duration: float = 0.04, **extra) -> tuple:
    """Six-step chopped drive from standstill into a viscous load (diode free-wheeling every 4th tick)."""
    params = bldc_params(**{'integration.max_step': max_step, 'load.mode': 'viscous',
                            'load.viscous': 0.004, 'protection.peak_current': 0.0, **extra})
    plant = PlantCore(params)
    ctrl = SixStepChopper(plant.motor.backemf, on=3, period=4)
    traj = CoSimulation(plant, ctrl).run(duration)
    return plant, traj


def test_energy_balance_closes_over_a_switching_run():
    plant, traj = _switching_run(25e-6)
    s = traj.states[-1]
    e_in = s.energy_dc_source
    assert e_in > 1.0 and s.energy_copper_loss > 0.01 and s.energy_mechanical_output > 0.01
    assert any('current zero' in what for _, what in plant.events)   # diodes did extinguish
    residual = (e_in - (s.energy_stored - traj.states[0].energy_stored) - s.energy_copper_loss
                - s.energy_device_loss - s.energy_friction_loss - s.energy_mechanical_output)
    assert abs(residual) < 0.005 * e_in, residual / e_in


@pytest.mark.parametrize('motor, midpoint', [('ozturk_bldc', 'c'), ('fstp_pm_blac', 'a')])
def test_energy_balance_with_device_drops_four_switch_split_capacitors(motor, midpoint):
    params = plant_params(motor, **{'inverter.topology': 4, 'inverter.midpoint_phase': midpoint,
                            'dc_link.mode': 'split_capacitors', 'inverter.v_ce': 0.9,
                            'inverter.v_d': 1.25, 'inverter.r_on': 0.075,
                            'load.mode': 'dynamometer', 'load.speed': 20.0,
                            'motor.initial_speed': 20.0})
    plant = PlantCore(params)
    pattern = [(True, False, False, True, False, False), (False, True, True, False, False, False),
               (True, False, False, False, False, False), (False, False, False, True, False, False),
               (False, False, True, False, False, True), (False, False, False, True, True, False)]
    traj = CoSimulation(plant, ScriptedGates(lambda k: pattern[(k // 7) % 6], topology=4)).run(0.02)
    s = traj.states[-1]
    assert s.energy_device_loss > 0.0
    residual = (s.energy_dc_source - (s.energy_stored - traj.states[0].energy_stored)
                - s.energy_copper_loss - s.energy_device_loss - s.energy_friction_loss
                - s.energy_mechanical_output)
    throughput = abs(s.energy_dc_source) + s.energy_copper_loss + s.energy_device_loss
    assert abs(residual) < 0.005 * throughput


def test_halving_the_inner_step_does_not_move_currents_or_torque():
    _, coarse = _switching_run(25e-6, duration=0.02)
    _, fine = _switching_run(12.5e-6, duration=0.02)
    i1, i2 = coarse.array('phase_current'), fine.array('phase_current')
    t1, t2 = coarse.array('electromagnetic_torque'), fine.array('electromagnetic_torque')
    assert np.max(np.abs(i1)) > 5.0
    assert np.max(np.abs(i1 - i2)) < 0.005 * np.max(np.abs(i1))
    assert np.max(np.abs(t1 - t2)) < 0.005 * np.max(np.abs(t1))


def test_locked_rotor_rl_step_response_is_exact():
    params = bldc_params(**{'load.mode': 'dynamometer', 'load.speed': 0.0,
                            'motor.initial_angle': 0.3, 'protection.peak_current': 0.0})
    plant = PlantCore(params)
    traj = CoSimulation(plant, ScriptedGates(lambda k: A_PLUS_B_MINUS)).run(0.01)
    t = np.array(traj.times)
    m = plant.motor
    tau = m.inductance / m.resistance                 # two phases in series: 2(L-M) / 2R
    expected = plant.dc.voltage / (2.0 * m.resistance) * (1.0 - np.exp(-t / tau))
    i = traj.array('phase_current')
    assert np.max(np.abs(i[:, 0] - expected)) < 1e-9 * expected.max()
    assert np.all(i[:, 0] == -i[:, 1]) and np.all(i[:, 2] == 0.0)


@pytest.mark.parametrize('inertia', [1e-4, 4e-4])
def test_acceleration_under_constant_torque_follows_inertia(inertia):
    torque = 0.05                                    # the load machine drives: T_L = -0.05 N m
    params = bldc_params(**{'motor.inertia': inertia, 'motor.friction': 0.0, 'load.torque': -torque})
    plant = PlantCore(params)
    traj = CoSimulation(plant, ScriptedGates(lambda k: ALL_OFF)).run(0.02)
    w = traj.array('mechanical_speed')
    t = np.array(traj.times)
    assert np.max(np.abs(traj.array('phase_current'))) == 0.0     # EMF stays below the link
    np.testing.assert_allclose(w, torque / inertia * t, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(traj.array('mechanical_angle'), 0.5 * torque / inertia * t ** 2,
                               rtol=1e-9, atol=1e-12)


def test_open_phase_stays_exactly_zero_until_forward_biased():
    # a+ b- with c carrying current first (c- on), then c turned off: its current
    # free-wheels through the upper c diode, is extinguished (located event) and
    # the c leg floats. The dynamometer then speeds up so e_c forward-biases a diode.
    speed = [5.0]
    params = bldc_params(**{'load.mode': 'dynamometer', 'load.speed': 5.0, 'motor.initial_speed': 5.0,
                            'protection.peak_current': 0.0})
    plant = PlantCore(params)

    def gates(k):
        return (True, False, False, True, False, True) if k < 20 else A_PLUS_B_MINUS

    def ramp(cosim):
        if cosim.plant.step >= 400:
            speed[0] = min(300.0, speed[0] + 0.5)
            cosim.plant.load.speed = speed[0]
    traj = CoSimulation(plant, ScriptedGates(gates), on_tick=ramp).run(0.05)
    i = traj.array('phase_current')
    v = traj.array('terminal_voltage')
    vdc = plant.dc.voltage
    assert abs(i[19, 2]) > 0.1                                   # c conducted while switched
    zero_events = [t for t, what in plant.events if what == 'current zero phase c']
    assert zero_events and 20 * 25e-6 < zero_events[0] < 400 * 25e-6
    open_c = i[:, 2] == 0.0
    k_zero = int(zero_events[0] // plant.base_tick) + 1
    assert not open_c[k_zero - 1] and open_c[k_zero:400].all()   # extinguished and stays exactly 0
    # while open, the floating terminal stays inside the diodes' blocking range
    assert np.all(v[open_c, 2] >= -1e-9) and np.all(v[open_c, 2] <= vdc + 1e-9)
    # at high speed the back-EMF forward-biases a c diode: current flows again, terminal on a rail
    conducting = np.flatnonzero(~open_c[400:]) + 400
    assert conducting.size > 10
    rails = np.minimum(np.abs(v[conducting, 2]), np.abs(v[conducting, 2] - vdc))
    assert np.max(rails) < 1e-9


def test_protection_trip_is_located_inside_the_sample_and_latched():
    params = bldc_params(**{'load.mode': 'dynamometer', 'load.speed': 0.0, 'motor.initial_angle': 0.3})
    plant = PlantCore(params)
    m = plant.motor
    tau = m.inductance / m.resistance
    i_ss = plant.dc.voltage / (2.0 * m.resistance)
    t_trip = -tau * math.log(1.0 - 24.0 / i_ss)
    ctrl = ScriptedGates(lambda k: A_PLUS_B_MINUS)
    cosim = CoSimulation(plant, ctrl)
    cosim.run(0.005)
    assert plant.trip.tripped
    assert plant.trip.trip_time == pytest.approx(t_trip, abs=1e-12)
    assert t_trip % plant.base_tick > 1e-7                     # really inside a sample
    assert plant.trip.trip_current == pytest.approx(24.0, rel=1e-12)
    traj = cosim.trajectory
    k_trip = int(t_trip // plant.base_tick)
    peak = np.max(np.abs(traj.array('phase_current')))
    assert peak <= 24.0 + 1e-9                                   # not smeared past the level
    st = traj.states[k_trip + 1]
    assert st.protection & 1 and st.safe_state and not any(st.applied_switch_on)
    # latched: commands keep asking for a+ b-, the currents decay to zero and stay there
    assert traj.states[-1].phase_current == (0.0, 0.0, 0.0)
    ok, _ = plant.reset_protection()
    assert ok and not plant.trip.tripped
    cosim.run(steps=2)
    assert plant.i[0] > 0.0 and plant.state().applied_switch_on == A_PLUS_B_MINUS


def test_trip_after_a_parameter_change_opens_all_switches():
    # A runtime parameter change rebuilds the plant's constants while a+ b- conducts; the trip
    # that follows ends the tick with all legs off, which the rebuilt plant had not seen yet.
    params = bldc_params(**{'load.mode': 'dynamometer', 'load.speed': 0.0, 'motor.initial_angle': 0.3})
    plant = PlantCore(params)
    plant.apply_gates(A_PLUS_B_MINUS)
    plant.advance()
    plant.reconfigure({**params, 'sensors.current_offset': [0.5, 0.0, 0.0]})
    while not plant.trip.tripped and plant.time < 0.005:
        plant.advance()
    assert plant.trip.tripped and plant.state().applied_switch_on == ALL_OFF
    assert plant.faults.counts[int(FaultKind.MOTOR_OVER_CURRENT)] == 1


def test_reset_is_refused_while_the_current_is_above_the_level():
    params = bldc_params(**{'load.mode': 'dynamometer', 'load.speed': 0.0, 'motor.initial_angle': 0.3,
                            'protection.peak_current': 24.0})
    plant = PlantCore(params)
    plant.apply_gates(A_PLUS_B_MINUS)
    while not plant.trip.tripped:
        plant.advance()
    plant.trip.level = 1.0                                       # current still above the new level
    ok, message = plant.reset_protection()
    assert not ok and 'above' in message and plant.trip.tripped


def test_dynamometer_holds_speed_against_motor_torque():
    params = bldc_params(**{'load.mode': 'dynamometer', 'load.speed': 40.0, 'motor.initial_speed': 40.0,
                            'protection.peak_current': 0.0})
    plant = PlantCore(params)
    traj = CoSimulation(plant, SixStepChopper(plant.motor.backemf, 3, 4)).run(0.02)
    w = traj.array('mechanical_speed')
    assert np.all(w == 40.0)
    te = traj.array('electromagnetic_torque')
    assert np.mean(te[100:]) > 0.1
    # the dynamometer absorbs the motor torque (minus friction) on average
    tl = traj.array('load_torque')
    assert np.mean(tl[100:]) == pytest.approx(np.mean(te[100:]) - plant.motor.friction * 40.0, rel=0.05)
    plant.reconfigure({**plant.params, 'load.speed': 10.0})     # changeable at runtime
    CoSimulation(plant, SixStepChopper(plant.motor.backemf, 3, 4)).run(steps=10)
    assert plant.omega == 10.0


def test_four_switch_midpoint_drifts_with_midpoint_phase_current():
    params = bldc_params(**{'inverter.topology': 4, 'inverter.midpoint_phase': 'c',
                            'dc_link.mode': 'split_capacitors', 'load.mode': 'dynamometer',
                            'load.speed': 0.0, 'motor.initial_angle': 0.2})
    plant = PlantCore(params)
    # SW1 on (a to P) for 2 ms, then SW2 on (a to N) for 2 ms: i_c = -i_a flows through the midpoint
    traj = CoSimulation(plant, ScriptedGates(lambda k: (k < 80, k >= 80, False, False, False, False),
                                             topology=4)).run(0.004)
    i_c = traj.array('phase_current')[:, 2]
    v_lo = traj.array('lower_capacitor_voltage')
    v_up = traj.array('upper_capacitor_voltage')
    t = np.array(traj.times)
    c_sum = 2 * 270e-6
    charge = np.concatenate(([0.0], np.cumsum(0.5 * (i_c[1:] + i_c[:-1]) * np.diff(t))))
    expected = plant.dc.voltage / 2 - charge / c_sum
    assert np.max(np.abs(v_lo - v_lo[0])) > 0.5                  # it really drifts
    assert np.max(np.abs(v_lo - expected)) < 0.01 * np.max(np.abs(v_lo - v_lo[0]))
    np.testing.assert_allclose(v_up + v_lo, plant.dc.voltage, rtol=1e-12)
    assert v_lo[80] > v_lo[0]                                    # a+: current returns into the midpoint
    assert np.argmax(v_lo) > 75                                 # and reverses after SW2 takes over


def _dead_time_run(dead_time: float) -> float:
    """i_a after a+ b- (build-up), a- b- (free-wheel), then a+ b- again for one tick."""
    params = bldc_params(**{'inverter.dead_time': dead_time, 'load.mode': 'dynamometer',
                            'load.speed': 0.0, 'motor.initial_angle': 0.3,
                            'protection.peak_current': 0.0})
    plant = PlantCore(params)
    for gates, ticks in ((A_PLUS_B_MINUS, 30), ((False, True, False, True, False, False), 4),
                         (A_PLUS_B_MINUS, 1)):
        plant.apply_gates(gates)
        for _ in range(ticks):
            plant.advance()
    return plant.i[0]


def test_dead_time_delays_each_turn_on_by_the_dead_time():
    # Each turn-on (off -> a+/b- at t = 0, and a- -> a+ at tick 34 with i_a > 0, the lower
    # diode holding v_a at 0) takes V_dc t_dead of volt-seconds from the a-b loop
    # (2 (L - M), 2 R); each loss then decays with tau = (L - M)/R until tick 35.
    dead, tick = 5e-6, 25e-6
    m = PlantCore(bldc_params()).motor
    tau = m.inductance / m.resistance
    loss = _dead_time_run(0.0) - _dead_time_run(dead)
    step = 40 * math.sqrt(2) * dead / (2 * m.inductance)
    expected = step * (math.exp(-(35 * tick - dead / 2) / tau) + math.exp(-(tick - dead / 2) / tau))
    assert loss == pytest.approx(expected, rel=0.01)


@pytest.mark.parametrize('dead, max_step', [(10e-6, 5e-6), (12e-6, 5e-6), (5e-6, 5e-6),
                                             (3e-6, 5e-6), (24e-6, 25e-6 / 6)])
def test_integrated_time_equals_sim_time_when_the_dead_time_exceeds_the_inner_step(dead, max_step):
    # A gate change every tick puts a dead time in every tick. The rotor is held at constant
    # speed by the dynamometer, so the angle it turns through measures the time integrated:
    # before the fix a 10 us dead time with 5 us inner steps integrated 30 us per 25 us tick.
    tick, speed = 25e-6, 100.0
    params = bldc_params(**{'inverter.dead_time': dead, 'integration.max_step': max_step,
                            'load.mode': 'dynamometer', 'load.speed': speed,
                            'motor.initial_speed': speed, 'protection.peak_current': 0.0})
    plant = PlantCore(params)
    other = (False, True, True, False, False, False)
    peak = 0.0
    for k in range(100):
        plant.apply_gates(A_PLUS_B_MINUS if k % 2 == 0 else other)
        plant.advance()
        assert plant._elapsed == pytest.approx(tick, rel=1e-12, abs=1e-18), k
        peak = max(peak, abs(plant.i[0]))
    assert plant.time == pytest.approx(100 * tick)
    assert plant.theta_m == pytest.approx(speed * plant.time, rel=1e-12)
    assert peak > 0.01                                  # the legs did conduct


@pytest.mark.parametrize('source_current', [0.5, -0.2])
def test_current_fed_link_charges_the_capacitors_from_the_source_port(source_current):
    params = bldc_params(**{'dc_link.mode': 'current_fed', 'dc_link.source_current': source_current,
                            'inverter.topology': 4})
    plant = PlantCore(params)
    v0 = plant.dc.positive
    for _ in range(400):
        plant.advance()
    c_series = 1.0 / (1.0 / 270e-6 + 1.0 / 270e-6)
    assert plant.dc.positive - v0 == pytest.approx(source_current * 0.01 / c_series, rel=1e-9)
    assert abs(plant.energy_balance_error()) < 1e-6 * abs(plant.dc.energy_source)


# --- fault record (core/faults.py): every protection kind and shoot-through -------------------
def test_peak_current_trip_is_recorded_with_phase_time_and_safe_state_exit():
    params = bldc_params(**{'load.mode': 'dynamometer', 'load.speed': 0.0, 'motor.initial_angle': 0.3})
    plant = PlantCore(params)
    cosim = CoSimulation(plant, ScriptedGates(lambda k: A_PLUS_B_MINUS))
    traj = cosim.run(0.005)
    record = plant.faults
    assert record.counts[FaultKind.MOTOR_OVER_CURRENT] == 1 and record.total == 1
    assert record.first_kind == FaultKind.MOTOR_OVER_CURRENT
    assert record.first_time == pytest.approx(plant.trip.trip_time, abs=0.0)
    assert traj.end_state.startswith('ended in fault state motor_over_current (first fault at t = ')
    assert traj.fault_kinds == ('motor_over_current',)
    s = traj.states[-1]
    assert s.fault_count == 1 and s.fault_counts[FaultKind.MOTOR_OVER_CURRENT] == 1
    assert s.first_fault_kind == FaultKind.MOTOR_OVER_CURRENT and s.first_fault_time == record.first_time
    ok, _ = plant.reset_protection()
    assert ok
    events = record.drain()
    assert [e.kind for e in events] == [FaultKind.NONE] and 'safe state left' in events[0].text
    # the record is latched: a reset does not clear it; a later run without faults ends normally
    assert plant.state().fault_count == 1
    assert CoSimulation(plant, ScriptedGates(lambda k: ALL_OFF)).run(0.001).end_state == 'ended normally'


def test_a_run_without_faults_has_an_empty_record():
    plant, traj = _switching_run(25e-6, duration=0.002)
    assert plant.faults.total == 0 and not plant.faults.pending
    s = traj.states[-1]
    assert s.fault_count == 0 and s.first_fault_kind == 0 and math.isnan(s.first_fault_time)
    assert traj.end_state == 'ended normally' and traj.fault_kinds == ()


@pytest.mark.parametrize('policy', ['safe_state', 'interlock'])
def test_shoot_through_is_a_fault_under_both_policies(policy):
    plant = PlantCore(bldc_params(**{'inverter.shoot_through': policy, 'load.mode': 'dynamometer',
                                     'load.speed': 0.0, 'motor.initial_angle': 0.3}))
    a_shorted = (True, True, False, True, False, False)     # leg a both on, b lower
    traj = CoSimulation(plant, ScriptedGates(lambda k: a_shorted if k == 3 else A_PLUS_B_MINUS)).run(
        steps=8)
    record = plant.faults
    assert record.counts[FaultKind.SHOOT_THROUGH] == 1 and record.first_kind == FaultKind.SHOOT_THROUGH
    assert record.first_time == pytest.approx(3 * plant.base_tick)
    assert traj.fault_kinds == ('shoot_through',)
    s = traj.states[-1]
    assert s.fault_counts[FaultKind.SHOOT_THROUGH] == 1
    if policy == 'safe_state':
        assert s.safe_state and s.protection & 16 and not any(s.applied_switch_on)
        plant.reset_protection()
        assert not plant.state().safe_state and not plant.protection
    else:
        assert not s.safe_state and not s.protection
        # the interlocked tick applied leg a off, leg b lower; the next ticks a+ b- again
        assert traj.states[4].applied_switch_on == (False, False, False, True, False, False)
        assert s.applied_switch_on == A_PLUS_B_MINUS


def test_shoot_through_event_names_the_legs():
    plant = PlantCore(bldc_params())
    plant.apply_gates((True,) * 6)
    [event] = plant.faults.drain()
    assert event.kind == FaultKind.SHOOT_THROUGH and event.values['leg'] == 'a,b,c'
    assert 'leg a,b,c' in event.text and event.step == 0


def test_fault_kind_labels_and_message_constants_agree():
    from dtc_msgs.msg import PlantState
    for kind in FaultKind:
        assert getattr(PlantState, f'FAULT_{kind.name}') == kind
    assert len(PlantState().fault_counts) == len(FaultKind)
    assert fault_kind('boost_over_current') == FaultKind.BOOST_OVER_CURRENT
    with pytest.raises(ValueError, match='unknown fault kind'):
        fault_kind('overheat')


def test_undrained_fault_queue_is_bounded():
    record = FaultRecord()
    for k in range(PENDING_MAX + 10):
        record.record(FaultKind.COMMAND_TIMEOUT, k * 1e-3, k, 'late')
    assert len(record.pending) == PENDING_MAX and record.dropped == 10
    assert record.total == PENDING_MAX + 10 and record.first_time == 0.0
