"""Speed of the switching-level PFC front end (bldc_plant_sim.core.front_end), prints figures.

Base tick 12.5 us (= PFC period = one 80 kHz PWM period), one plant segment
per tick: DcLink(current_fed) mid-segment prediction -> FrontEnd.advance ->
link update with a resistive load, as PlantCore will do it. Cases:
- 'pfc filter'    : PfcCore closing the loop every tick, 25.4 V RMS, 100 ohm, EMI filter on
                    (inner step 1 us for the 35.6 kHz L1+L2 / C2 resonance);
- 'pfc no filter' : the same without the EMI filter (pieces = PWM edges + located events);
- 'rectifier'     : boost switch held off, 64.53 V RMS, 125 ohm, filter on;
- 'fe only'       : 'pfc filter' with a fixed duty (no PfcCore): the front end's own cost.
Each case is run --repeats times from the same state; the best wall time is reported.

    python benchmarks/bench_front_end.py [--duration 0.2] [--repeats 3]
"""
from __future__ import annotations

import argparse

from bldc_plant_sim.core.dc_link import DcLink
from bldc_plant_sim.core.front_end import FrontEnd
from drive_common.samples import PfcSample
from pfc_controller.core import PfcCore
from timing import best_of  # benchmarks/timing.py

TICK = 12.5e-6


def run(steps: int, fe: FrontEnd, dc: DcLink, r_load: float, core: PfcCore | None,
        duty: float | None) -> None:
    for k in range(steps):
        t = k * TICK
        if core is not None:
            cmd, _ = core.update(PfcSample(k, t, fe.rectified_voltage, fe.i_L, dc.positive))
            fe.set_duty(cmd.duty, cmd.enable)
        elif duty is not None:
            fe.set_duty(duty, True)
        vp, _ = dc.segment_voltages(TICK)
        q = fe.advance(t, TICK, vp)
        dc.source_current = q / TICK
        dc.draw(vp / r_load * TICK, 0.0, TICK, t)


def bench(name: str, duration: float, repeats: int, v_rms: float, r_load: float, v0: float,
          pfc: bool, duty: float | None = None, **fe_kw) -> float:
    steps = int(round(duration / TICK))
    def setup():
        return (FrontEnd(line_voltage=v_rms, **fe_kw), DcLink('current_fed', v0, 270e-6, 270e-6),
                PfcCore({}) if pfc else None)

    best, best_cpu, (fe, dc, _) = best_of(
        repeats, setup, lambda objs: run(steps, objs[0], objs[1], r_load, objs[2], duty))
    rate = steps / best
    ev = fe.event_counts
    print(f'{name:<16s} {steps:6d} samples: {rate:8.0f} /wall s, {steps / best_cpu:8.0f} /CPU s '
          f'(x{duration / best:5.3f} real time; V_o {dc.positive:6.2f} V; events: '
          f"{ev['zero']} zero, {ev['start']} start, {ev['overlap']} overlap)")
    return rate


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--duration', type=float, default=0.2, help='sim time per case [s]')
    ap.add_argument('--repeats', type=int, default=3, help='runs per case (best is reported)')
    a = ap.parse_args()
    bench('pfc filter', a.duration, a.repeats, 25.4, 100.0, 80.0, True)
    bench('pfc no filter', a.duration, a.repeats, 25.4, 100.0, 80.0, True, filter_enabled=False)
    bench('rectifier', a.duration, a.repeats, 64.53, 125.0, 80.0, False)
    bench('fe only', a.duration, a.repeats, 25.4, 100.0, 80.0, False, duty=0.55)
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
