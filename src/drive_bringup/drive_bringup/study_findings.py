"""Set the sampled-hysteresis study beside its first-order prediction (docs/studies.md).

    python -m drive_bringup.study_findings docs/studies/sampled_hysteresis_torque_deficit

Reads the study's results.parquet, adds the predicted deficit
(:func:`predicted_torque_deficit_N_m`), writes plots/deficit_vs_prediction.png and prints a
Markdown table.
"""
from __future__ import annotations

import argparse
from pathlib import Path

TORQUE_REFERENCE = 0.5157          # N m, the study's T*


def predicted_torque_deficit_N_m(sample_period: float, speed: float, torque_reference: float,
                                 backemf_constant: float = 0.0573, pole_pairs: int = 2,
                                 resistance: float = 0.315, self_inductance: float = 1.4e-3,
                                 mutual_inductance: float = 0.3125e-3) -> float:
    """First-order T* - mean torque [N m] of sampled hysteresis DTC, dT = k_t (E + R i) T_s / L_s
    (derivation: docs/studies.md), at sample period T_s [s] and mechanical speed w_m [rad/s].

    Defaults: the 000 Appendix A motor (motors/ozturk_bldc.yaml): K [V s/rad per electrical
    rad/s], p, R [ohm], L, M [H]. The current i is taken at T*.
    """
    k_t = 2.0 * pole_pairs * backemf_constant                      # N m/A
    emf = backemf_constant * pole_pairs * speed                    # V, phase flat top
    current = torque_reference / k_t                               # A
    return k_t * (emf + resistance * current) * sample_period / (self_inductance - mutual_inductance)


def compare(table):
    """The ok rows with measured and predicted deficit [N m] and their ratio."""
    ok = table[table['status'] == 'ok'].copy()
    ok['deficit_N_m'] = -ok['mean_torque_error_N_m']
    ok['predicted_N_m'] = [predicted_torque_deficit_N_m(ts, w, TORQUE_REFERENCE)
                           for ts, w in zip(ok['sample_period_s'], ok['speed_rad_s'])]
    ok['ratio'] = ok['deficit_N_m'] / ok['predicted_N_m']
    return ok


def plot(ok, path: Path) -> None:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    for i, (ts, group) in enumerate(ok.groupby('sample_period_s')):
        color = f'C{i}'
        ax.plot(group['speed_rad_s'], group['deficit_N_m'], 'o', color=color,
                label=f'T_s = {ts * 1e6:.0f} us')
        ax.plot(group['speed_rad_s'], group['predicted_N_m'], '-', color=color, lw=1)
    ax.set_xlabel('speed (dynamometer), mech. rad/s')
    ax.set_ylabel('T* - mean torque, N m')
    ax.set_title('sampled hysteresis DTC: simulated (o) vs first order (-)', fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def markdown(ok) -> str:
    lines = ['| T_s (us) | speed (rad/s) | simulated deficit (N m) | predicted (N m) | ratio |',
             '|---|---|---|---|---|']
    for _, r in ok.sort_values(['sample_period_s', 'speed_rad_s']).iterrows():
        lines.append(f'| {r["sample_period_s"] * 1e6:.1f} | {r["speed_rad_s"]:.0f} | '
                     f'{r["deficit_N_m"]:.4f} | {r["predicted_N_m"]:.4f} | {r["ratio"]:.2f} |')
    return '\n'.join(lines)


def main(argv=None) -> int:
    import pandas as pd
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('results', type=Path, help='the study results directory')
    args = parser.parse_args(argv)
    ok = compare(pd.read_parquet(args.results / 'results.parquet'))
    (args.results / 'plots').mkdir(exist_ok=True)
    plot(ok, args.results / 'plots' / 'deficit_vs_prediction.png')
    print(markdown(ok))
    print(f'\nratio simulated / predicted: median {ok["ratio"].median():.3f}, '
          f'range {ok["ratio"].min():.3f} .. {ok["ratio"].max():.3f} over {len(ok)} points')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
