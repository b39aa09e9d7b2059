"""The seeds' figures as PNG from bag columns (matplotlib, Agg backend, no ROS).

Each figure of :data:`ALL_FIGURES` takes the columns of :func:`drive_analysis.bag_columns.load_columns`
and an output path, and returns the path, or None when the bag lacks the data.
"""
from __future__ import annotations

from functools import partial
from pathlib import Path

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

STATE, STATUS = '/plant/state', '/dtc/status'


def _has(cols, topic, *names) -> bool:
    return topic in cols and all(n in cols[topic] and np.isfinite(cols[topic][n]).any() for n in names)


def _save(fig, path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def flux_locus(cols, path):
    """Estimated stator flux locus psi_beta vs psi_alpha (Wb)."""
    if not _has(cols, STATUS, 'flux_alpha', 'flux_beta'):
        return None
    fig, ax = plt.subplots(figsize=(5, 5))
    ax.plot(cols[STATUS]['flux_alpha'], cols[STATUS]['flux_beta'], lw=0.6)
    ax.set(xlabel='psi_alpha (Wb)', ylabel='psi_beta (Wb)', title='Stator flux locus', aspect='equal')
    ax.grid(True)
    return _save(fig, path)


def _time_plot(cols, path, ylabel: str, title: str, required, lines):
    """Plot over t (s) the lines (topic, field, column or None, plot options) the data has;
    None unless some (topic, field) of required is there."""
    if not any(_has(cols, topic, name) for topic, name in required):
        return None
    fig, ax = plt.subplots(figsize=(8, 4))
    for topic, name, column, options in lines:
        if _has(cols, topic, name):
            values = cols[topic][name]
            ax.plot(cols[topic]['t'], values if column is None else values[:, column], **options)
    ax.set(xlabel='t (s)', ylabel=ylabel, title=title)
    ax.legend(), ax.grid(True)
    return _save(fig, path)


# the plots over time: true (plant) and controller signals, SI units
TIME_PLOTS = {
    'torque': dict(ylabel='torque (N m)', title='Electromagnetic torque',
                   required=[(STATUS, 'torque_reference'), (STATE, 'electromagnetic_torque')],
                   lines=[(STATE, 'electromagnetic_torque', None, dict(lw=0.6, label='true')),
                          (STATUS, 'torque_estimate', None, dict(lw=0.6, label='estimate')),
                          (STATUS, 'torque_reference', None, dict(lw=1.2, label='reference'))]),
    'phase_currents': dict(ylabel='current (A)', title='Phase currents',
                           required=[(STATE, 'phase_current')],
                           lines=[(STATE, 'phase_current', k, dict(lw=0.6, label=f'i_{name}'))
                                  for k, name in enumerate('abc')]),
    'speed': dict(ylabel='speed (rad/s)', title='Mechanical speed',
                  required=[(STATE, 'mechanical_speed')],
                  lines=[(STATE, 'mechanical_speed', None, dict(label='true')),
                         (STATUS, 'speed_reference', None, dict(label='reference'))]),
    'rotor_angle': dict(ylabel='angle (rad)', title='Electrical rotor angle',
                        required=[(STATE, 'rotor_angle')],
                        lines=[(STATE, 'rotor_angle', None, dict(lw=0.8, label='true')),
                               (STATUS, 'rotor_angle_estimate', None,
                                dict(lw=0.8, ls='--', label='estimated'))]),
}


def grid(cols, path):
    """Grid voltage (V) and line current (A)."""
    if not _has(cols, STATE, 'grid_voltage', 'grid_current'):
        return None
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.plot(cols[STATE]['t'], cols[STATE]['grid_voltage'], lw=0.8, color='C0', label='v_grid')
    ax.set(xlabel='t (s)', ylabel='voltage (V)', title='Grid voltage and current')
    ax2 = ax.twinx()
    ax2.plot(cols[STATE]['t'], cols[STATE]['grid_current'], lw=0.8, color='C1', label='i_grid')
    ax2.set_ylabel('current (A)')
    ax.grid(True)
    fig.legend(loc='upper right')
    return _save(fig, path)


ALL_FIGURES = {'flux_locus': flux_locus,
               **{name: partial(_time_plot, **spec) for name, spec in TIME_PLOTS.items()}, 'grid': grid}


def draw_all(cols, out_dir) -> dict[str, str]:
    """Draw every figure the data allows into out_dir; {name: png path}."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    drawn = {}
    for name, draw in ALL_FIGURES.items():
        path = draw(cols, out_dir / f'{name}.png')
        if path is not None:
            drawn[name] = str(path)
    return drawn
