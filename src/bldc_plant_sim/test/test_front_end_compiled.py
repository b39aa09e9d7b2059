"""The compiled front-end kernels give bit-identical trajectories to the same code interpreted."""
import numpy as np

from bldc_plant_sim.core.dc_link import DcLink
from bldc_plant_sim.core.front_end import FrontEnd
from bldc_plant_sim.core.front_end_kernel import filter_substeps
from drive_common.compiled import jit_disabled
from drive_testing.compiled_parity import differing, interpreted_and_compiled, requires_jit

pytestmark = requires_jit()

TICK = 12.5e-6
# (line V rms, load ohm, initial link V, duty, front-end keywords): filter and no-filter pieces,
# the rectifier's starts and zeros, bridge overlap and over-current trips.
CASES = {'filter': (25.4, 100.0, 80.0, 0.4, {}),
         'no_filter': (25.4, 100.0, 80.0, 0.4, {'filter_enabled': False}),
         'rectifier': (64.53, 125.0, 0.0, 0.0, {'filter_enabled': False}),
         'over_current': (25.4, 20.0, 40.0, 0.9, {'over_current_limit': 3.0})}


def front_end_runs(steps: int) -> dict:
    """State and ledger of every case after each tick (FrontEnd + current-fed DcLink + load)."""
    out = {}
    for name, (v_rms, r_load, v0, duty, kw) in CASES.items():
        fe, dc = FrontEnd(line_voltage=v_rms, **kw), DcLink('current_fed', v0, 270e-6, 270e-6)
        rows = []
        for k in range(steps):
            fe.set_duty(duty, duty > 0.0)
            vp, _ = dc.segment_voltages(TICK)
            q = fe.advance(k * TICK, TICK, vp)
            dc.source_current = q / TICK
            dc.draw(vp / r_load * TICK, 0.0, TICK, k * TICK)
            en = fe.energy
            rows.append([q, fe.i_f, fe.v_c, fe.i_L, fe.mode, fe.s, en.grid, en.delivered,
                         en.numerical, en.losses, fe.protection, dc.positive])
        out[name] = np.array(rows)
        out[name + ':events'] = np.array(sorted(fe.event_counts.items()), dtype=object)[:, 1].astype(float)
    return out


def test_kernels_are_compiled():
    assert not jit_disabled() and hasattr(filter_substeps, 'py_func')


def test_compiled_equals_interpreted_bit_for_bit(tmp_path):
    interpreted, compiled = interpreted_and_compiled('test_front_end_compiled:front_end_runs', [3000],
                                                     tmp_path)
    events = dict(zip(sorted(('zero', 'start', 'overlap', 'overlap_end', 'over_current', 'over_voltage')),
                      compiled['over_current:events']))
    assert events['over_current'] > 0 and events['overlap'] > 0 and compiled['rectifier:events'].sum() > 0
    assert differing(interpreted, compiled) == []
