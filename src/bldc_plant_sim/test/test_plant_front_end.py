"""PlantCore with the boost PFC front end wired in (000 ch. III): samples, commands, energy, convergence.

The plant runs at the PFC rate (base tick 12.5 us = one 80 kHz PWM period):
grid -> EMI filter -> bridge -> boost -> split capacitors (DcLink current_fed)
-> six-switch inverter -> 000 BLDC. The balance is
grid input = stored - stored_0 + losses (motor, inverter, front end) + mechanical work.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from bldc_plant_sim.core.cosim import CoSimulation
from bldc_plant_sim.core.plant import PlantCore
from drive_common.parameters import ParameterError
from pfc_controller.core import PfcCore
from plant_test_helpers import SixStepChopper, bldc_params

TICK = 12.5e-6
FE = {'base_tick': TICK, 'integration.max_step': TICK, 'dtc_period': TICK, 'pfc_period': TICK,
      'pfc_enabled': True, 'dc_link.mode': 'current_fed', 'dc_link.voltage': 80.0,
      'front_end.enabled': True, 'front_end.line_voltage': 25.4}


def _fe_params(**extra) -> dict:
    # The motor turns at 150 rad/s (a load machine holds it): the back-EMF bounds the chopped
    # phase currents to a few amperes, as under the DTC (see the note on the link prediction).
    return bldc_params(**{**FE, 'load.mode': 'dynamometer', 'load.speed': 150.0,
                          'motor.initial_speed': 150.0, **extra})


def _run(duration: float, **extra):
    plant = PlantCore(_fe_params(**extra))
    chopper = SixStepChopper(plant.motor.backemf, on=3, period=4)
    traj = CoSimulation(plant, chopper, PfcCore({}), record_every=2).run(duration)
    return plant, traj


def _residual(s, s0) -> float:
    return (s.energy_grid_input - (s.energy_stored - s0.energy_stored) - s.energy_copper_loss
            - s.energy_device_loss - s.energy_front_end_loss - s.energy_friction_loss
            - s.energy_mechanical_output)


@pytest.mark.parametrize('filter_enabled', [True, False])
def test_energy_balance_closes_grid_to_shaft(filter_enabled):
    plant, traj = _run(0.06, **{'front_end.filter.enabled': filter_enabled})
    s, s0 = traj.states[-1], traj.states[0]
    assert s.energy_grid_input > 1.0 and s.energy_front_end_loss > 0.01
    assert s.energy_mechanical_output > 0.01 and s.energy_copper_loss > 0.001
    assert s.energy_dc_source == 0.0                   # internal with the front end
    assert any('current zero' in what for _, what in plant.events)
    assert abs(_residual(s, s0)) < 0.005 * s.energy_grid_input, _residual(s, s0) / s.energy_grid_input
    assert plant.energy_balance_error() == pytest.approx(_residual(s, s0), abs=1e-9)


def test_halving_the_inner_steps_does_not_move_the_result():
    _, coarse = _run(0.03)
    _, fine = _run(0.03, **{'integration.max_step': TICK / 2, 'front_end.max_step': 0.5e-6})
    for name in ('dc_link_voltage', 'inductor_current', 'grid_current', 'phase_current',
                 'electromagnetic_torque'):
        a, b = coarse.array(name), fine.array(name)
        scale = np.max(np.abs(a))
        assert scale > 0.5, name
        assert np.max(np.abs(a - b)) < 0.005 * scale, (name, np.max(np.abs(a - b)) / scale)


def test_samples_and_state_carry_the_front_end():
    plant = PlantCore(_fe_params())
    assert plant.pfc_sample().output_voltage == pytest.approx(80.0)
    plant.apply_duty(0.5, True)
    for _ in range(int(round(1 / 240 / TICK))):        # to the line peak
        plant.advance()
    sample = plant.pfc_sample()
    assert sample.step == plant.step and sample.time == plant.time
    assert sample.rectified_voltage == pytest.approx(25.4 * math.sqrt(2.0), rel=0.02)
    assert sample.inductor_current == plant.fe.i_L > 0.0
    s = plant.state()
    assert s.grid_voltage == pytest.approx(25.4 * math.sqrt(2.0), rel=1e-3)
    assert math.isfinite(s.grid_current) and s.inductor_current == sample.inductor_current
    assert s.boost_duty == 0.5 and s.boost_switch_enabled
    assert s.energy_grid_input > 0.0 and s.energy_front_end_loss > 0.0
    # Safe state: the boost switch is held off whatever the duty command says: no switch
    # conduction loss accrues (it did while switching) and the inductor current flows only
    # through the boost diode.
    switch_loss, diode_loss = plant.fe.energy.switch, plant.fe.energy.diode
    assert switch_loss > 0.0
    plant.enter_safe_state(8)
    plant.apply_duty(0.9, True)
    plant.advance()
    s = plant.state()
    assert not s.boost_switch_enabled and s.boost_duty == 0.0 and s.safe_state
    assert plant.fe.energy.switch == switch_loss
    assert plant.fe.energy.diode > diode_loss
    plant.leave_safe_state(8)
    assert plant.fe.switch_enabled and plant.fe.duty == 0.9


def test_without_the_front_end_nothing_changes():
    plant = PlantCore(bldc_params())
    assert plant.fe is None and plant.pfc_sample() is None
    s = plant.state()
    assert math.isnan(s.grid_voltage) and math.isnan(s.inductor_current)
    assert s.energy_grid_input == 0.0 and s.energy_front_end_loss == 0.0


def test_boost_protection_bits_are_reported_in_plant_state():
    plant = PlantCore(_fe_params(**{'front_end.over_voltage_limit': 75.0}))
    plant.apply_duty(0.3, True)
    plant.advance()
    s = plant.state()
    assert s.protection & 4 and not s.protection & 2 and not s.boost_switch_enabled
    plant.reconfigure({**plant.params, 'front_end.over_voltage_limit': 140.0,
                       'front_end.over_current_limit': 0.5})
    plant.apply_duty(0.9, True)
    for _ in range(400):
        plant.advance()
    assert plant.fe.event_counts['over_current'] >= 1
    assert plant.fe.i_L < 0.5 + 1e-6 or not plant.fe.gate


def test_line_step_and_filter_rebuild_keep_the_balance_closed():
    plant, traj = _run(0.02)
    cosim = CoSimulation(plant, SixStepChopper(plant.motor.backemf, on=3, period=4), PfcCore({}))
    plant.reconfigure({**plant.params, 'front_end.line_voltage': 35.0, 'front_end.line_phase': 0.3})
    cosim.run(0.01)
    plant.reconfigure({**plant.params, 'front_end.filter.enabled': False})
    assert not plant.fe.filter_enabled
    cosim.run(0.01)
    grid = plant.fe.energy.grid
    assert abs(plant.energy_balance_error()) < 0.005 * grid


@pytest.mark.parametrize('changes, reason', [
    ({'front_end.enabled': True}, 'current_fed'),
    ({'pfc_enabled': True, 'base_tick': TICK, 'integration.max_step': TICK}, 'front end'),
    ({'front_end.pwm_carrier': 'square'}, 'not one of'),
    ({'front_end.line_voltage': -1.0}, 'below the minimum'),
])
def test_front_end_parameters_are_checked_with_a_reason(changes, reason):
    with pytest.raises(ParameterError, match=reason):
        bldc_params(**changes)


def test_front_end_cannot_be_switched_on_after_the_start():
    plant = PlantCore(bldc_params(**{'dc_link.mode': 'current_fed'}))
    plant.advance()
    with pytest.raises(ParameterError, match='front_end.enabled'):
        plant.reconfigure({**plant.params, 'front_end.enabled': True})


def test_boost_protections_are_recorded_as_faults():
    from bldc_plant_sim.core.faults import FaultKind
    plant = PlantCore(_fe_params(**{'front_end.over_voltage_limit': 75.0}))
    plant.apply_duty(0.3, True)
    plant.advance()
    [event] = plant.faults.drain()
    assert event.kind == FaultKind.BOOST_OVER_VOLTAGE and 'over-voltage' in event.text
    assert event.time == pytest.approx(0.0) and plant.faults.first_kind == FaultKind.BOOST_OVER_VOLTAGE
    plant.reconfigure({**plant.params, 'front_end.over_voltage_limit': 140.0,
                       'front_end.over_current_limit': 0.5})
    plant.apply_duty(0.9, True)
    for _ in range(400):
        plant.advance()
    oc = plant.fe.event_counts['over_current']
    assert oc >= 1 and plant.faults.counts[FaultKind.BOOST_OVER_CURRENT] == oc
    first_oc = next(e for e in plant.faults.drain() if e.kind == FaultKind.BOOST_OVER_CURRENT)
    assert 'i_L = ' in first_oc.text and first_oc.time > 0.0
    assert plant.state().fault_counts[FaultKind.BOOST_OVER_VOLTAGE] == 1
