"""Plots of a study's results table (matplotlib, PNG).

One varied parameter: each metric against it (the mean over repeats, the
spread as error bars). Two: a heat map per metric when both are numeric,
else one line per value of the non-numeric one (e.g. a compensation method)
against the numeric one. Sampled studies (random / Latin hypercube) and
more than two parameters: a scatter of each metric against each parameter.
Only points with status ok are plotted.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np


def _numeric(table, column: str) -> bool:
    import pandas as pd
    return pd.api.types.is_numeric_dtype(table[column])


def _figure():
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    return plt


def plot_study(study, table, out_dir: Path, dpi: int = 80) -> list[Path]:
    """Write one PNG per metric into out_dir/plots; return their paths."""
    plt = _figure()
    ok = table[table['status'] == 'ok']
    names = [a.name for a in study.axes]
    folder = Path(out_dir) / 'plots'
    folder.mkdir(parents=True, exist_ok=True)
    files = []
    for metric in study.metrics:
        data = ok.dropna(subset=[metric])
        if data.empty:
            continue
        fig, ax = plt.subplots(figsize=(5.0, 3.6))
        ax.set_ylabel(metric)
        if len(names) == 1 and study.axes[0].values:
            stats = data.groupby(names[0])[metric].agg(['mean', 'std']).reset_index()
            ax.errorbar(stats[names[0]], stats['mean'], yerr=stats['std'].fillna(0.0), marker='o')
            ax.set_xlabel(names[0])
        elif len(names) == 2 and all(a.values for a in study.axes):
            x, y = names if _numeric(data, names[0]) else names[::-1]
            if _numeric(data, x) and _numeric(data, y):
                grid = data.pivot_table(index=y, columns=x, values=metric, aggfunc='mean')
                image = ax.imshow(grid.values, origin='lower', aspect='auto', cmap='viridis')
                ax.set_xticks(range(len(grid.columns)), [f'{v:.3g}' for v in grid.columns])
                ax.set_yticks(range(len(grid.index)), [f'{v:.3g}' for v in grid.index])
                middle = np.nanmean(grid.values)
                for (i, j), value in np.ndenumerate(grid.values):
                    ax.text(j, i, f'{value:.3g}', ha='center', va='center', fontsize=7,
                            color='k' if value > middle else 'w')
                fig.colorbar(image, ax=ax, label=metric)
                ax.set_ylabel(y)
            else:
                for label, group in data.groupby(y):
                    stats = group.groupby(x)[metric].mean()
                    ax.plot(stats.index, stats.values, marker='o', label=str(label))
                ax.legend(title=y, fontsize=8)
            ax.set_xlabel(x)
        else:
            for name in names:
                ax.scatter(data[name], data[metric], s=12, label=name)
            ax.set_xlabel(', '.join(names))
            if len(names) > 1:
                ax.legend(fontsize=8)
        ax.set_title(f'{study.name}: {metric}', fontsize=9)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        path = folder / f'{metric}.png'
        fig.savefig(path, dpi=dpi)
        plt.close(fig)
        files.append(path)
    return files
