"""The fused compiled loop (drive_bringup.fused) gives the per-sample path's trajectory bit for bit."""
import math
from dataclasses import astuple, is_dataclass

import numpy as np
import pytest

from bldc_plant_sim.core.cosim import CoSimulation
from bldc_plant_sim.core.plant import PlantCore
from drive_bringup import headless
from drive_bringup.fused import FusedDtcLoop
from drive_bringup.headless import run_headless
from drive_bringup.scenario import load_scenario
from drive_common.uris import resolve_path
from drive_testing.compiled_parity import differing, interpreted_and_compiled, requires_jit
from dtc_controller.core.controller import DtcCore
from dtc_controller.core.modes.three_phase_pmsm import ThreePhaseBase
from dtc_controller.core.modes.two_phase_base import TwoPhaseModeBase

# each shipped DTC mode: two-phase six / four switch, fstp (four-switch three-phase) voltage and
# current model, dtifc sensorless, pmsm (sstp)
SCENARIOS = ['two_phase_six_switch_torque_step', 'two_phase_four_switch_flux_control',
             'fstp_voltage_model_proposed_compensation', 'fstp_current_model_full_load',
             'three_phase_dtifc_sensorless', 'sstp_voltage_model_simple_compensation']


class CountingLoop(FusedDtcLoop):
    """FusedDtcLoop that counts the ticks it ran compiled and those it left to Python."""

    def __init__(self, **kwargs) -> None:
        super().__init__(**kwargs)
        self.fused = self.python = 0

    def chunk(self, cosim, steps):
        done = super().chunk(cosim, steps)
        self.fused += done
        self.python += done == 0
        return done


def scenario(name: str, duration: float = 0.01, **plant):
    sc = load_scenario(resolve_path(f'package://drive_bringup/scenarios/{name}.yaml'))
    sc = sc.shortened(min(duration, sc.duration))
    sc.node_parameters['plant'].update(plant)
    return sc


def same(a, b) -> bool:
    """Bit-identical values (floats by their bits, so -0.0 != 0.0 and NaN == NaN), same types."""
    if is_dataclass(a) and is_dataclass(b):
        return type(a) is type(b) and same(astuple(a), astuple(b))
    if isinstance(a, tuple) and isinstance(b, tuple):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, float):
        return (a != a and b != b) or (a == b and math.copysign(1.0, a) == math.copysign(1.0, b))
    return type(a) is type(b) and a == b


def assert_same_trajectory(a, b) -> None:
    for name in ('steps', 'times', 'states', 'dtc_status', 'pfc_status', 'commands'):
        la, lb = getattr(a, name), getattr(b, name)
        assert len(la) == len(lb), name
        bad = [n for n, (x, y) in enumerate(zip(la, lb)) if not same(x, y)]
        assert bad == [], f'{name} differs first at record {bad[:1]}'
    aa, bb = a.as_arrays(), b.as_arrays()
    assert aa.keys() == bb.keys()
    assert [k for k in bb if aa[k].dtype != bb[k].dtype or not np.array_equal(aa[k], bb[k], equal_nan=True)] == []
    assert (a.end_state, a.fault_kinds) == (b.end_state, b.fault_kinds)


def run_both(sc, record_every=None):
    loop = CountingLoop()
    real = headless.FusedDtcLoop
    headless.FusedDtcLoop = lambda: loop
    try:
        fused = run_headless(sc, record_every=record_every)
    finally:
        headless.FusedDtcLoop = real
    return fused, run_headless(sc, record_every=record_every, fused=False), loop


@requires_jit()
@pytest.mark.parametrize('name', SCENARIOS)
def test_shipped_scenarios_fused_equal_per_sample(name):
    sc = scenario(name)
    fused, per_sample, loop = run_both(sc)
    # compiled but for the tick(s) up to the DTC sample that applies a scripted change
    assert loop.fused + loop.python == per_sample.final_step >= 200
    assert loop.python <= 2 * len(sc.events)
    assert len(per_sample.trajectory) > 100
    assert_same_trajectory(fused.trajectory, per_sample.trajectory)
    assert fused.arrays().keys() == per_sample.arrays().keys()
    assert differing(fused.arrays(), per_sample.arrays()) == []


@requires_jit()
@pytest.mark.parametrize('name', [SCENARIOS[0], SCENARIOS[4]])
def test_status_arrays_of_compiled_blocks_are_built_without_objects(name, monkeypatch):
    """arrays() reads the DTC statuses of compiled records from the kernel outputs: no
    DtcStatusSample is built, and every array has the per-sample path's dtype, shape and bits."""
    sc = scenario(name)
    per_sample = run_headless(sc, fused=False).arrays()
    fused = run_headless(sc)

    def refuse(*args):
        raise AssertionError('a status object was built for arrays()')
    for mode in (TwoPhaseModeBase, ThreePhaseBase):
        monkeypatch.setattr(mode, 'status_of', refuse)
    arrays = fused.arrays()
    status = sorted(k for k in per_sample if k.startswith('dtc/status.'))
    assert len(status) > 20 and status == sorted(k for k in arrays if k.startswith('dtc/status.'))
    assert [k for k in status if (arrays[k].dtype, arrays[k].shape) != (per_sample[k].dtype, per_sample[k].shape)
            or arrays[k].tobytes() != per_sample[k].tobytes()] == []


@requires_jit()
def test_trip_delay_missing_sensor_and_sparse_records_equal_per_sample():
    """A peak-current trip ends a chunk (the fault is recorded in Python) and the run goes on;
    computation_delay, a missing current sensor (reconstructed), an encoder offset, dead time
    and device drops, records every third tick and none."""
    sc = scenario('two_phase_four_switch_torque_step', 0.01, **{
        'protection.peak_current': 2.5, 'computation_delay': True, 'sensors.current_count': 2,
        'sensors.encoder_offset': 0.01, 'inverter.dead_time': 2e-6, 'inverter.v_ce': 1.0,
        'inverter.v_d': 0.8})
    for record_every in (3, 0):
        fused, per_sample, loop = run_both(sc, record_every)
        assert loop.fused > 100 and loop.python == 0
        assert fused.fault_kinds == ('motor_over_current',)
        assert_same_trajectory(fused.trajectory, per_sample.trajectory)


def test_event_log_and_latch_equal_per_sample():
    """The plant's located events (current zeros, the trip) and the held command of the latch."""
    sc = scenario('two_phase_six_switch_torque_step', 0.01, **{
        'protection.peak_current': 2.4, 'computation_delay': True, 'inverter.v_ce': 1.0, 'inverter.v_d': 0.8})
    runs = []
    for fused in (FusedDtcLoop(chunk_records=64), None):
        plant = PlantCore(sc.node_parameters['plant'])
        cosim = CoSimulation(plant, DtcCore(sc.node_parameters['dtc_controller']), fused=fused)
        runs.append((cosim.run(0.01), plant.events, cosim.schedule._held, plant.faults.first_text))
    (a, ev_a, held_a, text_a), (b, ev_b, held_b, text_b) = runs
    assert len(ev_b) > 30 and [what for _, what in ev_b if 'trip' in what] == ['trip phase b']
    assert ev_b[-1][0] > ev_b[0][0] + 0.005                 # over many chunks of 64 records
    assert ev_a == ev_b and held_a == held_b and text_a == text_b
    assert_same_trajectory(a, b)


def test_noisy_sensors_stay_on_the_per_sample_path():
    sc = scenario('two_phase_six_switch_torque_step', 0.002, **{'sensors.current_noise': 0.01})
    fused, per_sample, loop = run_both(sc)
    assert loop.fused == 0 and loop.python > 0
    assert_same_trajectory(fused.trajectory, per_sample.trajectory)


def test_on_tick_runs_between_chunks_and_can_stop_the_run():
    """A study's deadline: on_tick before every ON_TICK_EVERY-th tick, its exception ends the run."""
    sc = scenario('two_phase_six_switch_torque_step', 0.04)
    sc.duration = 0.5                  # 15000 ticks: on_tick at 0, 4096, 8192 (raises), not 12288
    seen = []

    def hook(cosim):
        seen.append(cosim.plant.step)
        if len(seen) == 3:
            raise TimeoutError('deadline')
    with pytest.raises(TimeoutError):
        run_headless(sc, on_tick=hook)
    every = headless.ON_TICK_EVERY
    assert seen == [0, every, 2 * every]


def fused_arrays(names: list, duration: float) -> dict:
    """Headless arrays of the fused and the per-sample path: 'name:fused|per_sample:key'."""
    out = {}
    for name in names:
        sc = scenario(name, duration)
        for label, fused in (('fused', True), ('per_sample', False)):
            out.update({f'{name}:{label}:{k}': v for k, v in run_headless(sc, fused=fused).arrays().items()})
    return out


@requires_jit()
def test_fused_loop_interpreted_equals_compiled(tmp_path):
    """NUMBA_DISABLE_JIT=1 in a subprocess runs the same fused loop as plain Python: same arrays."""
    names = ['two_phase_six_switch_torque_step', 'three_phase_dtifc_sensorless']
    interpreted, compiled = interpreted_and_compiled('test_fused_loop:fused_arrays', [names, 0.001],
                                                     tmp_path)
    assert differing(interpreted, compiled) == []
    for name in names:
        assert np.ptp(compiled[f'{name}:fused:dtc/status.torque_estimate']) > 0.0
        assert differing({k.split(':', 2)[2]: v for k, v in compiled.items() if ':fused:' in k and k.startswith(name)},
                         {k.split(':', 2)[2]: v for k, v in compiled.items()
                          if ':per_sample:' in k and k.startswith(name)}) == []


def test_constant_gates_fused_equal_per_sample():
    """A controller with constant_gates (FixedGateCore) runs in the loop without its calls."""
    from bldc_plant_sim.parameters import plant_params
    from drive_testing.fixed_commands import FixedGateCore
    params = plant_params('ozturk_bldc', **{'base_tick': 25e-6, 'dtc_period': 50e-6, 'load.mode': 'viscous',
                                            'load.viscous': 0.004, 'computation_delay': True})
    runs, loop = [], CountingLoop(chunk_records=100)
    for fused in (loop, None):
        plant = PlantCore(params)
        cosim = CoSimulation(plant, FixedGateCore(), fused=fused)
        runs.append((cosim.run(0.01), plant.events))
    (a, ev_a), (b, ev_b) = runs
    assert loop.fused == 400 and len(b) == 401 and ev_a == ev_b
    assert np.ptp(b.array('mechanical_speed')) > 1.0 and b.commands[2][0].switch_on == FixedGateCore.switch_on
    assert_same_trajectory(a, b)


@requires_jit()
def test_plant_event_between_chunks_equal_per_sample():
    """A scripted plant change (load step at 0.3 s): the run's final record of the first part is
    replaced by the next chunk's first record, as on the per-sample path."""
    sc = scenario('two_phase_six_switch_flux_locus', 0.302)
    fused, per_sample, loop = run_both(sc)
    assert loop.python == 0 and loop.fused == per_sample.final_step
    assert_same_trajectory(fused.trajectory, per_sample.trajectory)
    assert differing(fused.arrays(), per_sample.arrays()) == []


# Scenarios with the front end and PfcCore (plant parameters changed): the shipped operating
# point; the plain rectifier (no PFC); boost over-current trips without the EMI filter with the
# computation delay; a latched over-voltage trip at start with the sawtooth carrier.
PFC_CASES = {
    'fig_3_5': ('pfc_no_load_fig_3_5', {}),
    'rectifier': ('pfc_without_pfc_fig_3_4', {}),
    'over_current_no_filter_delay': ('pfc_no_load_fig_3_5', {
        'front_end.filter.enabled': False, 'front_end.over_current_limit': 0.5, 'computation_delay': True}),
    'latched_over_voltage': ('pfc_no_load_fig_3_5', {
        'front_end.protection_latched': True, 'front_end.over_voltage_limit': 79.0, 'dc_link.voltage': 81.0,
        'front_end.pwm_carrier': 'sawtooth'}),
}


def pfc_run(sc, fused):
    """A PFC scenario's cores as run_headless builds them, records every second tick; (trajectory,
    plant)."""
    params = dict(sc.node_parameters['plant'], pfc_enabled='pfc_controller' in sc.node_parameters)
    plant = PlantCore(params)
    plant.fe.log_switching_events = True
    cosim = CoSimulation(plant, *headless.build_controllers(sc), record_every=2, fused=fused)
    return cosim.run(sc.duration), plant


@requires_jit()
@pytest.mark.parametrize('case', PFC_CASES)
def test_pfc_scenarios_fused_equal_per_sample(case):
    """The front end and PfcCore in the fused loop: trajectory (PlantState with the front end's
    fields, PFC statuses and duty commands), the plant's and the front end's event logs, event
    counts and fault record bit for bit as the per-sample path; a boost trip ends a chunk."""
    name, plant_params = PFC_CASES[case]
    sc = scenario(name, 0.01, **plant_params)
    loop = CountingLoop(chunk_records=300)
    (a, plant_a), (b, plant_b) = pfc_run(sc, loop), pfc_run(sc, None)
    assert loop.python == 0 and loop.fused == plant_b.step == 800
    assert_same_trajectory(a, b)
    assert a.status_arrays('pfc').keys() == b.status_arrays('pfc').keys()
    assert differing(a.status_arrays('pfc'), b.status_arrays('pfc')) == []
    fe_a, fe_b = plant_a.fe, plant_b.fe
    assert (plant_a.events, fe_a.events, fe_a.event_counts) == (plant_b.events, fe_b.events, fe_b.event_counts)
    assert same(fe_a.last_event, fe_b.last_event)
    assert plant_a.faults.first_text == plant_b.faults.first_text
    assert list(plant_a.faults.counts) == list(plant_b.faults.counts)
    assert sum(fe_b.event_counts.values()) > 0 and len(fe_b.events) > 0
    duties = [d for _, d in b.commands if d is not None]
    if case != 'rectifier':
        assert len(duties) == 400 and max(d.duty for d in duties) > 0.0
    if case == 'over_current_no_filter_delay':
        assert fe_b.event_counts['over_current'] >= 5 and b.fault_kinds == ('boost_over_current',)
    if case == 'latched_over_voltage':
        assert fe_b.event_counts['over_voltage'] == 1 and b.fault_kinds == ('boost_over_voltage',)
        assert fe_b.over_voltage and not any(d.duty > 0.0 and s.boost_switch_enabled
                                             for (_, d), s in zip(b.commands, b.states) if d is not None)


def fused_pfc_arrays(duration: float) -> dict:
    """Trajectory and PFC status arrays of the fused PFC cases (PFC_CASES), 'case:key'."""
    out = {}
    for case, (name, plant_params) in PFC_CASES.items():
        trajectory, plant = pfc_run(scenario(name, duration, **plant_params), FusedDtcLoop())
        out.update({f'{case}:{k}': v for k, v in trajectory.as_arrays().items() if v is not None})
        out.update({f'{case}:pfc/{k}': v for k, v in trajectory.status_arrays('pfc').items()})
        out[f'{case}:fe'] = plant.fe.fx.copy()
    return out


@requires_jit()
def test_fused_pfc_loop_interpreted_equals_compiled(tmp_path):
    """NUMBA_DISABLE_JIT=1 runs the fused PFC loop (front-end, plant, PFC and DTC kernels) as plain
    Python: the same arrays and front-end state."""
    interpreted, compiled = interpreted_and_compiled('test_fused_loop:fused_pfc_arrays', [0.0008], tmp_path)
    assert len(compiled['fig_3_5:time']) == 33 and np.ptp(compiled['fig_3_5:inductor_current']) > 0.0
    assert differing(interpreted, compiled) == []
