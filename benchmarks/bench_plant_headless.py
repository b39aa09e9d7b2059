"""Speed of the headless plant loop (prints figures; not a timed test).

Six-switch BLDC of 000 Appendix A at T_s = 25 us with the default inner step
(one exact step per sample unless an event splits it), driven through
bldc_plant_sim.core.cosim.CoSimulation by trivial controller cores:
- 'fixed'     : drive_common FixedGateCore (a+ b-) against a dynamometer at 100 rad/s
                (current limited by the EMF, no trips);
- 'six-step'  : hall six-step commutation chopped 3 ticks on / 1 off, from standstill
                into a viscous load (diode free-wheeling and extinction events).
Target: >= 40 000 samples per wall second on one core without per-sample
recording; the recorded variant (plant/state every sample) is printed too.
'fixed' runs again in the fused compiled loop (drive_bringup.fused: FixedGateCore's
constant_gates, no per-sample Python): goal >= 2M samples/s; the chopper is a Python
controller and stays on the per-sample path.
Each case is run --repeats times and the best time is reported (the machine
may be shared); samples per CPU second are printed beside the wall figure.

    python benchmarks/bench_plant_headless.py [--duration 1.0] [--repeats 3]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'src' / 'bldc_plant_sim' / 'test'))

from bldc_plant_sim.core.cosim import CoSimulation  # noqa: E402
from bldc_plant_sim.core.plant import PlantCore  # noqa: E402
from bldc_plant_sim.parameters import plant_params  # noqa: E402
from drive_bringup.fused import FusedDtcLoop  # noqa: E402
from drive_testing.fixed_commands import FixedGateCore  # noqa: E402
from plant_test_helpers import SixStepChopper  # noqa: E402
from timing import best_of  # benchmarks/timing.py


def bench(name: str, params: dict, make_ctrl, duration: float, record_every: int,
          repeats: int, fused: bool = False) -> float:
    """Best of `repeats` runs (wall clock and process CPU time); returns samples per wall second."""
    def setup():
        plant = PlantCore(params)
        return plant, CoSimulation(plant, make_ctrl(plant), record_every=record_every,
                                   fused=FusedDtcLoop() if fused else None)

    steps = PlantCore(params).step_of(duration)
    best_wall, best_cpu, (plant, _) = best_of(repeats, setup, lambda objs: objs[1].run(steps=steps))
    rate = steps / best_wall
    s = plant.state()
    print(f'{name:<34s} {steps:7d} samples: {rate:8.0f} /wall s, {steps / best_cpu:8.0f} /CPU s '
          f'(x{duration / best_wall:4.2f} real time; {s.mechanical_speed:6.1f} rad/s, '
          f'{len(plant.events)} located events)')
    return rate


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--duration', type=float, default=1.0, help='sim time per case [s]')
    ap.add_argument('--repeats', type=int, default=3, help='runs per case (best is reported)')
    args = ap.parse_args()
    base = {'base_tick': 25e-6, 'dtc_period': 25e-6}
    fixed = plant_params('ozturk_bldc', **base, **{'load.mode': 'dynamometer', 'load.speed': 100.0,
                                                   'protection.peak_current': 0.0,
                                                   'motor.initial_speed': 100.0})
    chop = plant_params('ozturk_bldc', **base, **{'load.mode': 'viscous', 'load.viscous': 0.004,
                                                  'protection.peak_current': 0.0})
    print(f'python {sys.version.split()[0]}, T_s = 25 us, default inner step (25 us)')
    rates = [
        bench('fixed gates, no recording', fixed, lambda p: FixedGateCore(), args.duration, 0,
              args.repeats),
        bench('six-step chopper, no recording', chop, lambda p: SixStepChopper(p.motor.backemf, 3, 4),
              args.duration, 0, args.repeats),
        bench('six-step chopper, state recorded', chop,
              lambda p: SixStepChopper(p.motor.backemf, 3, 4), args.duration, 1, args.repeats),
    ]
    bench('(warm-up of the fused loop)', fixed, lambda p: FixedGateCore(), 0.01, 0, 1, fused=True)
    fused = [bench('fixed gates, fused, no recording', fixed, lambda p: FixedGateCore(), args.duration, 0,
                   args.repeats, fused=True),
             bench('fixed gates, fused, state recorded', fixed, lambda p: FixedGateCore(), args.duration, 1,
                   args.repeats, fused=True)]
    print(f'headless loop, plant + trivial controller: {min(rates[:2]):.0f} samples/s '
          f'(target >= 40000)')
    print(f'fused loop, plant + constant gates: {fused[0]:.0f} samples/s unrecorded, {fused[1]:.0f} '
          'recorded (goal >= 2M)')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
