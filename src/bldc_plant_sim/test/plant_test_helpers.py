"""Helpers for the bldc_plant_sim tests: small controller cores and plant factories."""
from __future__ import annotations

import math

from bldc_plant_sim.core.backemf import BackEmfShape
from bldc_plant_sim.parameters import plant_params
from drive_common.samples import ALL_OFF, GateSample


def six_step_table(shape: BackEmfShape) -> dict:
    """hall code -> (SW1..SW6) driving + current into the phase with the largest k, - out of the smallest."""
    table = {}
    for n in range(6):
        theta = (n + 0.5) * math.pi / 3.0
        k = shape.lookup(theta)
        hi = max(range(3), key=lambda x: k[x])
        lo = min(range(3), key=lambda x: k[x])
        sw = [False] * 6
        sw[2 * hi] = True
        sw[2 * lo + 1] = True
        table[shape.hall_code(theta)] = tuple(sw)
    return table


class SixStepChopper:
    """Open-loop six-step commutation from the halls, chopped: on `on` ticks of every `period`.

    During the off ticks all switches are open (the currents free-wheel through
    the diodes back into the link, so diode extinction events occur).
    """

    def __init__(self, shape: BackEmfShape, on: int = 3, period: int = 4, topology: int = 6) -> None:
        self.table = six_step_table(shape)
        self.on, self.period, self.topology = on, period, topology

    def update(self, sample):
        sw = self.table.get(sample.hall_code, ALL_OFF) if sample.step % self.period < self.on else ALL_OFF
        return GateSample(step=sample.step, topology=self.topology, switch_on=sw), None


class ScriptedGates:
    """Gate tuple as a function of the step: fn(step) -> (SW1..SW6)."""

    def __init__(self, fn, topology: int = 6) -> None:
        self.fn, self.topology = fn, topology

    def update(self, sample):
        return GateSample(step=sample.step, topology=self.topology, switch_on=tuple(self.fn(sample.step))), None


IDEAL_SWITCHES = {'inverter.v_ce': 0.0, 'inverter.v_d': 0.0, 'inverter.r_on': 0.0}
"""000's simulations neglect the devices (the schema defaults are 001 Table IV)."""


def bldc_params(**overrides) -> dict:
    """000 Appendix A motor (ozturk_bldc.yaml), six-switch, ideal switches and source, plus overrides."""
    return plant_params('ozturk_bldc', **{**IDEAL_SWITCHES, **overrides})
