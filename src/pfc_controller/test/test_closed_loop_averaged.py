"""PfcCore closed around an averaged boost PFC model (checks the per-unit interpretation).

The model lives here on purpose (the switching-level stage belongs to the
plant package): ideal grid -> diode bridge -> L = 1 mH boost inductor (current
clamped at 0: discontinuous conduction) -> switch/diode averaged with the
duty over each sample -> C = 270 uF + 270 uF in series (135 uF) -> resistive
load. Integrated with 4 Euler sub-steps per 12.5 us sample; the duty computed
from the sample at t_k acts over [t_k, t_k + T_s) as in the lockstep plant.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from drive_analysis.metrics import pfc
from drive_common.samples import PfcSample
from pfc_controller.core import PfcCore

T_S = 12.5e-6
LINE_HZ = 60.0
SAMPLES_PER_3_CYCLES = 4000            # 3 / 60 Hz at 80 kHz, an exact integer


class AveragedBoost:
    """Averaged diode-bridge boost with a resistive load (SI units)."""

    def __init__(self, v_rms: float, r_load: float, v_o: float | None = None,
                 inductance: float = 1e-3, capacitance: float = 135e-6) -> None:
        self.v_rms, self.r_load = v_rms, r_load
        self.L, self.C = inductance, capacitance
        self.i_l = 0.0
        self.v_o = v_rms * math.sqrt(2) if v_o is None else v_o   # diode-charged start
        self.t = 0.0

    def grid_voltage(self, t: float) -> float:
        return self.v_rms * math.sqrt(2) * math.sin(2 * math.pi * LINE_HZ * t)

    def advance(self, duty: float, enable: bool, substeps: int = 4) -> None:
        d = duty if enable else 0.0
        h = T_S / substeps
        for n in range(substeps):
            v_in = abs(self.grid_voltage(self.t + n * h))
            self.i_l = max(self.i_l + h * (v_in - (1.0 - d) * self.v_o) / self.L, 0.0)
            self.v_o += h * ((1.0 - d) * self.i_l - self.v_o / self.r_load) / self.C
        self.t += T_S


def run(core: PfcCore, plant: AveragedBoost, duration: float, log: dict, step0: int = 0) -> int:
    """Lockstep loop: sample, control, apply, advance; logs grid v, grid i, v_o, B."""
    n = int(round(duration / T_S))
    for k in range(step0, step0 + n):
        v_grid = plant.grid_voltage(plant.t)
        sample = PfcSample(k, plant.t, abs(v_grid), plant.i_l, plant.v_o)
        command, status = core.update(sample)
        log['v'].append(v_grid)
        log['i'].append(math.copysign(plant.i_l, v_grid))
        log['vo'].append(plant.v_o)
        log['b'].append(status.voltage_loop_output)
        plant.advance(command.duty, command.enable)
    return step0 + n


def last_cycles(log: dict, key: str, cycles: int = 6) -> np.ndarray:
    return np.asarray(log[key][-SAMPLES_PER_3_CYCLES * cycles // 3:])


@pytest.fixture(scope='module')
def scenario():
    """Soft start at 25.4 V RMS / 92 ohm, then a load step to 59 ohm, then a line step to 35 V RMS."""
    core = PfcCore({})
    plant = AveragedBoost(v_rms=25.4, r_load=92.0)
    phases = {}
    k = 0
    for name, duration, change in [('start', 0.40, None),
                                   ('load_step', 0.30, ('r_load', 59.0)),
                                   ('line_step', 0.30, ('v_rms', 35.0))]:
        if change:
            setattr(plant, *change)
        log = {'v': [], 'i': [], 'vo': [], 'b': []}
        k = run(core, plant, duration, log, k)
        phases[name] = log
    return phases


def _metric(name: str, log: dict, cycles: int = 6) -> float:
    """drive_analysis.metrics.pfc.<name> of the log's last line cycles."""
    t = np.arange(len(log['v'])) * T_S
    arrays = {'plant/state.time': t, 'plant/state.grid_voltage': log['v'],
              'plant/state.grid_current': log['i'], 'plant/state.dc_link_voltage': log['vo']}
    if name.startswith('line_'):      # the last whole cycles of the window
        return getattr(pfc, name)(arrays, cycles=cycles)
    return getattr(pfc, name)(arrays, t_start=t[-SAMPLES_PER_3_CYCLES * cycles // 3])


@pytest.mark.parametrize('phase', ['start', 'load_step', 'line_step'])
def test_holds_80_v_with_unity_power_factor(scenario, phase):
    log = scenario[phase]
    assert abs(_metric('mean_output_voltage_V', log) - 80.0) < 1.0
    assert _metric('line_power_factor', log) >= 0.99
    assert _metric('line_current_thd_pct', log) <= 8.0
    assert _metric('line_displacement_factor', log) >= 0.99
    # The 120 Hz output ripple is set by the capacitor: dV_pp ~ P / (omega C V_o).
    expected_pp = _metric('line_real_power_W', log) / (2 * math.pi * LINE_HZ * 135e-6 * 80.0)
    assert _metric('output_voltage_ripple_pp_V', log) == pytest.approx(expected_pp, rel=0.15)


def test_recovers_after_load_step(scenario):
    vo = np.asarray(scenario['load_step']['vo'])
    dip = 80.0 - vo.min()
    assert 1.0 < dip < 25.0          # the step is seen, and it is bounded
    settled = vo[int(0.15 / T_S):]   # 150 ms after the step
    assert abs(settled.mean() - 80.0) < 1.0


def test_recovers_after_line_step(scenario):
    vo = np.asarray(scenario['line_step']['vo'])
    settled = vo[int(0.15 / T_S):]
    assert abs(settled.mean() - 80.0) < 1.0
    assert vo.max() < 140.0


def test_feedforward_makes_b_the_per_unit_power_demand(scenario):
    """Interpretation check: P_in = B * V_min * I_base / 2 whatever the line voltage."""
    p_base = 28.28 * 10.0 / 2
    for phase in ['load_step', 'line_step']:
        log = scenario[phase]
        b_mean = last_cycles(log, 'b').mean()
        assert _metric('line_real_power_W', log) / p_base == pytest.approx(b_mean, rel=0.05)
    # Same load, line 25.4 V -> 35 V RMS: B (the power demand) stays put.
    b_before = last_cycles(scenario['load_step'], 'b').mean()
    b_after = last_cycles(scenario['line_step'], 'b').mean()
    assert b_after == pytest.approx(b_before, rel=0.05)


def test_without_control_the_line_current_is_distorted():
    """Boost held off = diode rectifier into the capacitor: the metric must see it."""
    core = PfcCore({'enable': False})
    plant = AveragedBoost(v_rms=25.4, r_load=92.0)
    log = {'v': [], 'i': [], 'vo': [], 'b': []}
    run(core, plant, 0.2, log)
    assert _metric('line_power_factor', log) < 0.9 and _metric('line_current_thd_pct', log) > 50.0
