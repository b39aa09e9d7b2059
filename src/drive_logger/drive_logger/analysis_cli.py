"""``analyze``: metrics (JSON) and figures (PNG) of a recorded drive run, without ROS.

    analyze bags/run1 [--out DIR] [--rated-torque 0.3] [--window T0 T1]
            [--pole-pairs P] [--line-frequency 60] [--salvage]

Steady-state metrics (THD, TRF, ripple, balance, PF) use the window (default:
the last half of the run); the rise time uses the largest torque-reference
step; estimation errors use every sample matched by ``step``.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from drive_logger.analysis import figures, metrics
from drive_logger.analysis.data import load_columns
from drive_logger.bag_reader import BagReadError

STATE, STATUS = '/plant/state', '/dtc/status'


def _window(cols, t0, t1):
    t = cols['t']
    mask = (t >= t0) & (t <= t1)
    return {k: v[mask] for k, v in cols.items() if len(v) == len(t)}


def _matched(a, b, field_a, field_b):
    """Values of a[field_a] and b[field_b] at the steps both topics have."""
    _, ia, ib = np.intersect1d(a['step'], b['step'], return_indices=True)
    return a[field_a][ia], b[field_b][ib]


def _safe(fn, *args, **kwargs):
    try:
        value = fn(*args, **kwargs)
    except (ValueError, ZeroDivisionError, IndexError, FloatingPointError) as exc:
        return {'error': str(exc)}
    return value


def summarize(cols, rated_torque=None, window=None, line_frequency=60.0) -> dict:
    """The metrics of a run's columns (see module docstring)."""
    out: dict = {'topics': {t: int(len(c.get('step', []))) for t, c in cols.items()}}
    state, status = cols.get(STATE), cols.get(STATUS)
    if state is not None and len(state.get('t', [])) > 8:
        t = state['t']
        t0, t1 = window or (t[0] + 0.5 * (t[-1] - t[0]), t[-1])
        out['window'] = [float(t0), float(t1)]
        steady = _window(state, t0, t1)
        currents = steady['phase_current']
        i_ref = currents[:, int(np.nanargmax(np.nanstd(currents, axis=0)))]
        f1 = _safe(metrics.fundamental_frequency, steady['t'], i_ref)
        if isinstance(f1, float):
            out['current_fundamental_frequency'] = f1
            thd = [_safe(metrics.thd_percent, steady['t'], currents[:, k], f1) for k in range(3)]
            fund = [_safe(lambda k=k: float(metrics.harmonics(steady['t'], currents[:, k], f1, 1)[1]))
                    for k in range(3)]
            out['current_thd_percent'] = dict(zip('abc', thd))
            if all(isinstance(x, float) for x in thd):
                out['current_thd_total_percent'] = metrics.total_thd_percent(thd)
            if all(isinstance(x, float) for x in fund):
                out['current_balance'] = metrics.current_balance(fund)
        torque = steady['electromagnetic_torque']
        out['torque_ripple'] = metrics.ripple(torque)
        if rated_torque:
            out['torque_ripple_factor_percent'] = metrics.torque_ripple_factor_percent(torque, rated_torque)
        out['speed_ripple'] = metrics.ripple(steady['mechanical_speed'])
        grid_v, grid_i = steady.get('grid_voltage'), steady.get('grid_current')
        if grid_v is not None and np.isfinite(grid_v).all() and np.isfinite(grid_i).all():
            out['power_factor'] = _safe(metrics.power_factor, steady['t'], grid_v, grid_i, line_frequency)
            out['grid_current_thd_percent'] = _safe(metrics.thd_percent, steady['t'], grid_i, line_frequency)
    if status is not None and len(status.get('t', [])) > 1:
        step = metrics.largest_step(status['t'], status['torque_reference'])
        if step is not None and state is not None:
            t_step, before, after = step
            out['torque_step'] = {'time': t_step, 'from': before, 'to': after,
                                  'rise_time_10_90': metrics.rise_time(state['t'], state['electromagnetic_torque'],
                                                                       t_step, before, after)}
        if state is not None:
            est, true = _matched(status, state, 'torque_estimate', 'electromagnetic_torque')
            out['torque_estimation_error'] = metrics.error_stats(est, true)
            est, true = _matched(status, state, 'rotor_angle_estimate', 'rotor_angle')
            out['angle_estimation_error'] = metrics.error_stats(est, true, angle=True)
        out['flux_ripple'] = metrics.ripple(status['flux_magnitude'][np.isfinite(status['flux_magnitude'])]) \
            if np.isfinite(status['flux_magnitude']).any() else None
    return out


def json_safe(value):
    """JSON-safe copy: NaN/inf -> None, numpy scalars -> Python numbers."""
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog='analyze', description=__doc__.split('\n\n')[0])
    ap.add_argument('bag')
    ap.add_argument('--out', help='output directory (default <bag>_analysis)')
    ap.add_argument('--rated-torque', type=float, help='N m, T_rated of 001 eq. (40)')
    ap.add_argument('--window', type=float, nargs=2, metavar=('T0', 'T1'), help='steady-state window, s')
    ap.add_argument('--line-frequency', type=float, default=60.0, help='Hz, grid frequency for PF')
    ap.add_argument('--salvage', action='store_true', help='analyse the intact part of a damaged bag')
    args = ap.parse_args(argv)
    try:
        cols = load_columns(args.bag, salvage=args.salvage)
    except BagReadError as exc:
        print(f'analyze: error: {exc}', file=sys.stderr)
        return 2
    out_dir = Path(args.out or f'{args.bag.rstrip("/")}_analysis')
    out_dir.mkdir(parents=True, exist_ok=True)
    summary = summarize(cols, args.rated_torque, args.window, args.line_frequency)
    summary['figures'] = figures.draw_all(cols, out_dir)
    (out_dir / 'summary.json').write_text(json.dumps(json_safe(summary), indent=2))
    print(json.dumps(json_safe(summary), indent=2))
    return 0


if __name__ == '__main__':
    sys.exit(main())
