"""``analyze``: metrics (JSON) and figures (PNG) of a recorded drive run, without ROS.

    analyze bags/run1 [--out DIR] [--rated-torque 0.3] [--window T0 T1]
            [--line-frequency 60] [--salvage] [--namespace NS]

Steady-state metrics (THD, TRF, ripple, balance, PF) use the window (default:
the last half of the run); the rise time uses the largest torque-reference
step; estimation errors use every sample matched by ``step``.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from drive_analysis import figures
from drive_analysis.bag_columns import ANALYSED_TOPICS, load_columns
from drive_analysis.summary import json_safe, summarize
from drive_logger.bag_reader import BagReadError
from drive_common.cli_output import quiet_on_closed_pipe


@quiet_on_closed_pipe
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog='analyze', description=__doc__.split('\n\n')[0])
    ap.add_argument('bag', help='bag directory, or a directory of tables from drive_logger export --to parquet/csv')
    ap.add_argument('--out', help='output directory (default <bag>_analysis)')
    ap.add_argument('--rated-torque', type=float, help='N m, T_rated of 001 eq. (40)')
    ap.add_argument('--window', type=float, nargs=2, metavar=('T0', 'T1'), help='steady-state window, s')
    ap.add_argument('--line-frequency', type=float, default=60.0, help='Hz, grid frequency for PF')
    ap.add_argument('--salvage', action='store_true', help='analyse the intact part of a damaged bag')
    ap.add_argument('--namespace', default='auto',
                    help='the drive namespace to analyse in a bag of several (e.g. /drive1)')
    args = ap.parse_args(argv)
    try:
        cols = load_columns(args.bag, salvage=args.salvage, namespace=args.namespace)
    except BagReadError as exc:
        print(f'analyze: error: {exc}', file=sys.stderr)
        return 2
    if not cols:
        print(f'analyze: error: bag {args.bag!r} holds none of the topics analyze reads '
              f'({", ".join(ANALYSED_TOPICS)}, or their blocks)', file=sys.stderr)
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
