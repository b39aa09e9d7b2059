"""The seeds' figures as PNG from bag columns (matplotlib, Agg backend, no ROS).

Each function takes the columns of :func:`drive_analysis.bag_columns.load_columns`
and an output path, and returns the path, or None when the bag lacks the data.
"""
from __future__ import annotations

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


def _save_time_plot(fig, ax, path, ylabel: str, title: str) -> Path:
    """Label a plot over t (s), add its legend and grid, and save it."""
    ax.set(xlabel='t (s)', ylabel=ylabel, title=title)
    ax.legend(), ax.grid(True)
    return _save(fig, path)


def flux_locus(cols, path):
    """Estimated stator flux locus psi_beta vs psi_alpha (Wb)."""
    if not _has(cols, STATUS, 'flux_alpha', 'flux_beta'):
        return None
    fig, ax = plt.subplots(figsize=(5, 5))
    ax.plot(cols[STATUS]['flux_alpha'], cols[STATUS]['flux_beta'], lw=0.6)
    ax.set(xlabel='psi_alpha (Wb)', ylabel='psi_beta (Wb)', title='Stator flux locus', aspect='equal')
    ax.grid(True)
    return _save(fig, path)


def torque(cols, path):
    """Torque reference and estimate (controller) and true torque (plant), N m."""
    if not (_has(cols, STATUS, 'torque_reference') or _has(cols, STATE, 'electromagnetic_torque')):
        return None
    fig, ax = plt.subplots(figsize=(8, 4))
    if _has(cols, STATE, 'electromagnetic_torque'):
        ax.plot(cols[STATE]['t'], cols[STATE]['electromagnetic_torque'], lw=0.6, label='true')
    if _has(cols, STATUS, 'torque_estimate'):
        ax.plot(cols[STATUS]['t'], cols[STATUS]['torque_estimate'], lw=0.6, label='estimate')
    if _has(cols, STATUS, 'torque_reference'):
        ax.plot(cols[STATUS]['t'], cols[STATUS]['torque_reference'], lw=1.2, label='reference')
    return _save_time_plot(fig, ax, path, 'torque (N m)', 'Electromagnetic torque')


def phase_currents(cols, path):
    """True phase currents i_a, i_b, i_c (A)."""
    if not _has(cols, STATE, 'phase_current'):
        return None
    fig, ax = plt.subplots(figsize=(8, 4))
    for k, name in enumerate('abc'):
        ax.plot(cols[STATE]['t'], cols[STATE]['phase_current'][:, k], lw=0.6, label=f'i_{name}')
    return _save_time_plot(fig, ax, path, 'current (A)', 'Phase currents')


def speed(cols, path):
    """Mechanical speed (rad/s), true and reference."""
    if not _has(cols, STATE, 'mechanical_speed'):
        return None
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.plot(cols[STATE]['t'], cols[STATE]['mechanical_speed'], label='true')
    if _has(cols, STATUS, 'speed_reference'):
        ax.plot(cols[STATUS]['t'], cols[STATUS]['speed_reference'], label='reference')
    return _save_time_plot(fig, ax, path, 'speed (rad/s)', 'Mechanical speed')


def rotor_angle(cols, path):
    """Electrical rotor angle, true vs estimated (rad)."""
    if not _has(cols, STATE, 'rotor_angle'):
        return None
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.plot(cols[STATE]['t'], cols[STATE]['rotor_angle'], lw=0.8, label='true')
    if _has(cols, STATUS, 'rotor_angle_estimate'):
        ax.plot(cols[STATUS]['t'], cols[STATUS]['rotor_angle_estimate'], lw=0.8, ls='--', label='estimated')
    return _save_time_plot(fig, ax, path, 'angle (rad)', 'Electrical rotor angle')


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


ALL_FIGURES = {'flux_locus': flux_locus, 'torque': torque, 'phase_currents': phase_currents,
               'speed': speed, 'rotor_angle': rotor_angle, 'grid': grid}


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
