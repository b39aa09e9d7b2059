"""Synthetic back-EMF tables for the dtc_controller core tests (no plant code)."""
import math

import numpy as np
from dtc_controller.core.backemf_table import BackEmfTable

K_FLAT = 0.0573  # V s/rad, per-phase flat-top constant (about 0.1146 Wb / 2 of 000 Appendix A)


def trapezoid(theta: np.ndarray) -> np.ndarray:
    """Ideal 120-deg flat-top trapezoid with the fundamental's sign of -sin(theta), unit height."""
    x = np.mod(theta, 2 * np.pi)
    out = np.empty_like(x)
    for j, t in enumerate(x):
        d = math.degrees(t)
        if d < 30:
            out[j] = -d / 30.0
        elif d < 150:
            out[j] = -1.0
        elif d < 210:
            out[j] = -1.0 + (d - 150) / 30.0
        elif d < 330:
            out[j] = 1.0
        else:
            out[j] = 1.0 - (d - 330) / 30.0
    return out


def make_table(shape: str = 'trapezoid', points: int = 360, pole_pairs: int = 2, k: float = K_FLAT) -> BackEmfTable:
    th = np.arange(points) * (2 * np.pi / points)
    f = trapezoid if shape == 'trapezoid' else (lambda t: -np.sin(t))
    return BackEmfTable.from_phase_constants(*(k * f(th - s) for s in (0, 2 * np.pi / 3, 4 * np.pi / 3)),
                                             pole_pairs, source=f'test {shape}')


