"""Sensors sampled at t_k: seeded noise determinism, errors, encoder and halls."""
from __future__ import annotations

import math

import numpy as np
import pytest

from bldc_plant_sim.core.plant import PlantCore
from plant_test_helpers import bldc_params

NOISY = {'sensors.current_noise': 0.2, 'sensors.voltage_noise': 0.5, 'sensors.speed_noise': 0.1,
         'load.mode': 'dynamometer', 'load.speed': 30.0, 'motor.initial_speed': 30.0}


def _samples(seed: int, n: int = 2000, **extra):
    plant = PlantCore(bldc_params(**{**NOISY, 'sensors.seed': seed, **extra}))
    out = []
    for _ in range(n):
        out.append(plant.drive_sample())
        plant.advance()
    return plant, out


def test_noise_is_deterministic_for_a_seed_and_differs_between_seeds():
    _, a = _samples(7)
    _, b = _samples(7)
    _, c = _samples(8)
    assert [s.phase_current for s in a] == [s.phase_current for s in b]
    assert [s.dc_link_voltage for s in a] == [s.dc_link_voltage for s in b]
    assert [s.phase_current for s in a] != [s.phase_current for s in c]
    ia = np.array([s.phase_current[0] for s in a])        # true current is zero (open circuit)
    assert np.std(ia) == pytest.approx(0.2, rel=0.1) and abs(np.mean(ia)) < 0.02
    vdc = np.array([s.dc_link_voltage for s in a])
    assert np.std(vdc) == pytest.approx(0.5, rel=0.1)
    assert np.mean(vdc) == pytest.approx(40 * math.sqrt(2), abs=0.05)


def test_offset_gain_error_and_two_sensor_configuration():
    plant, s = _samples(0, n=1, **{'sensors.current_noise': 0.0, 'sensors.voltage_noise': 0.0,
                                   'sensors.speed_noise': 0.0, 'sensors.current_count': 2,
                                   'sensors.current_offset': [0.1, -0.2, 0.0],
                                   'sensors.voltage_gain_error': 0.01})
    ia, ib, ic = s[0].phase_current
    assert ia == 0.1 and ib == -0.2 and math.isnan(ic)
    assert s[0].dc_link_voltage == pytest.approx(1.01 * 40 * math.sqrt(2))
    assert s[0].mechanical_speed == 30.0


def test_encoder_counts_2048_pulses_in_quadrature_and_halls_follow_the_angle():
    plant = PlantCore(bldc_params(**{'load.mode': 'dynamometer', 'load.speed': 100.0,
                                     'motor.initial_speed': 100.0}))
    while plant.theta_m < 2 * math.pi:
        plant.advance()
    s = plant.drive_sample()
    assert s.encoder_count == math.floor(plant.theta_m / (2 * math.pi) * 8192)
    assert s.encoder_angle == pytest.approx((2 * plant.theta_m) % (2 * math.pi), abs=2 * 2 * math.pi / 8192)
    assert s.hall_code == plant.motor.backemf.hall_code(2 * plant.theta_m)
    assert s.hall_code in range(1, 7)
