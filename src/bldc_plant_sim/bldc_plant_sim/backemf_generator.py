"""Back-EMF generator test (000 §5.4): write the back-EMF table a controller loads.

The dynamometer drives the open-circuit motor at constant speed; e_ba = v_b - v_a and
e_ca = v_c - v_a over one electrical cycle, divided by omega_e, give k_ba, k_ca [V*s/rad]
(one sample every ``ticks_per_point`` base ticks, on the grid 2 pi n / points, the diodes kept
reverse-biased). Derived columns: docs/architecture.md (phase constants by 000 eq. (5.13)).
Pure Python (no ROS): ``backemf_generator --motor ozturk_bldc -o table.csv``.
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from drive_common import backemf_file
from drive_common.samples import ALL_OFF
from drive_common.signals import TWO_PI

from .core.plant import PlantCore
from .parameters import plant_params


def generator_test(params: dict, points: int = 252, speed: float = 30.0) -> dict:
    """Run the open-circuit test at a mechanical speed [rad/s] of at most speed (on the angle
    grid); returns {'columns', 'speed', 'ticks_per_point'}."""
    base = dict(params)
    tick = base['base_tick']
    p = int(base['motor.pole_pairs'])
    w_e_target = p * abs(speed)
    m = max(1, math.ceil(TWO_PI / (points * tick * w_e_target)))
    w_e = TWO_PI / (points * m * tick)
    base.update({'load.mode': 'dynamometer', 'load.speed': w_e / p, 'motor.initial_speed': w_e / p,
                 'motor.initial_angle': 0.0, 'protection.peak_current': 0.0})
    plant = PlantCore(base)
    limit = plant.dc.positive + 2.0 * plant.inverter.v_d
    peak = w_e * plant.motor.backemf.line_to_line_peak()
    if peak >= limit:
        raise ValueError(f'generator test: line-to-line EMF {peak:.2f} V at {w_e / p:.2f} rad/s would '
                         f'forward-bias the diodes (limit {limit:.2f} V); lower the speed')
    plant.apply_gates(ALL_OFF)
    k_ba = np.empty(points)
    k_ca = np.empty(points)
    for n in range(points):
        state = plant.state()
        if any(state.phase_current):
            raise RuntimeError('generator test: current flowed in the open-circuit test')
        v = state.terminal_voltage
        w = state.mechanical_speed * p
        k_ba[n] = (v[1] - v[0]) / w
        k_ca[n] = (v[2] - v[0]) / w
        for _ in range(m):
            plant.advance()
    return {'columns': backemf_file.columns_from_line_to_line(k_ba, k_ca), 'speed': w_e / p,
            'ticks_per_point': m}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog='backemf_generator', description=__doc__.split('\n')[0])
    parser.add_argument('--motor', default='ozturk_bldc', help='motor file (name in motors/ or path)')
    parser.add_argument('--points', type=int, default=252, help='points per electrical cycle (252)')
    parser.add_argument('--speed', type=float, default=30.0, help='test speed, mechanical rad/s (max)')
    parser.add_argument('-p', '--param', action='append', default=[], metavar='NAME=VALUE',
                        help='extra plant parameter (YAML value), repeatable')
    parser.add_argument('-o', '--output', default=None, help='output CSV (default backemf_<motor>.csv)')
    args = parser.parse_args(argv)
    import yaml  # noqa: PLC0415

    overrides = {name: yaml.safe_load(value)
                 for name, _, value in (item.partition('=') for item in args.param)}
    try:
        params = plant_params(args.motor, **overrides)
        result = generator_test(params, args.points, args.speed)
    except (ValueError, OSError) as exc:
        print(f'error: {exc}', file=sys.stderr)
        return 2
    out = Path(args.output or f'backemf_{Path(args.motor).stem}.csv')
    meta = {'pole_pairs': params['motor.pole_pairs'], 'points': args.points,
            'source': f'bldc_plant_sim generator test, motor {args.motor}, open circuit at '
                      f'{result["speed"]:.6g} mech rad/s',
            'convention': 'docs/architecture.md (k = d psi_r/d theta_e, e = omega_e k; '
                          'k_a,k_b,k_c without zero sequence, 000 eq. 5.13)'}
    backemf_file.write(out, result['columns'], meta)
    print(f'wrote {out} ({args.points} points, {result["speed"]:.4g} mech rad/s, '
          f'k_LL peak {np.max(np.abs(result["columns"]["k_ba"])):.6g} V s/rad)')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
