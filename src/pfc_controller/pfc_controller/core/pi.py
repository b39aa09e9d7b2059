"""Discrete PI controller with output limits and anti-windup (000 ch. III, G_v and G_i).

Series form, as TI's ``pid_reg3`` that the seed's F2812 implementation builds on: u_p = K_p e,
x[k] = x[k-1] + K_i u_p (K_i = T_s / T_i), u = clamp(u_p + x, lo, hi). Anti-windup by conditional
integration: beyond a limit the integrator advances at most to the value that puts the output on
it, and stays within [lo, hi]. Limits may be given per call (the current loop's move with the
duty feed-forward).
"""
from __future__ import annotations

from drive_common.compiled import interpreted, njit


@njit
def pi_update(kp: float, ki: float, lo: float, hi: float, integral: float, error: float):
    """One sample of the limited series PI (module doc): (output, integral, unlimited, saturated);
    saturated = output on a limit with the error pushing beyond it."""
    if lo > hi:  # degenerate window (e.g. feed-forward beyond the duty range)
        lo = hi
    proportional = kp * error
    candidate = integral + ki * proportional
    unlimited = proportional + candidate
    if unlimited > hi and error > 0.0:      # winding up: integrate only up to the limit
        candidate = max(integral, min(candidate, hi - proportional))
    elif unlimited < lo and error < 0.0:    # winding down
        candidate = min(integral, max(candidate, lo - proportional))
    integral = min(max(candidate, lo), hi)
    unlimited = proportional + integral
    if unlimited >= hi:
        return hi, integral, unlimited, unlimited > hi or error > 0.0
    if unlimited <= lo:
        return lo, integral, unlimited, unlimited < lo or error < 0.0
    return unlimited, integral, unlimited, False


_pi_update = interpreted(pi_update)   # PiController's per-call path (no dispatch cost)


class PiController:
    """Per-unit PI executed once per sample period (gains dimensionless)."""

    __slots__ = ('kp', 'ki', 'out_min', 'out_max', 'integral', 'output_unlimited', 'saturated')

    def __init__(self, kp: float, ki: float, out_min: float, out_max: float) -> None:
        if out_min > out_max:
            raise ValueError(f'PI limits reversed: {out_min} > {out_max}')
        self.kp = float(kp)
        self.ki = float(ki)
        self.out_min = float(out_min)
        self.out_max = float(out_max)
        self.integral = 0.0
        self.output_unlimited = 0.0
        self.saturated = False

    def reset(self, integral: float = 0.0) -> None:
        """Clear the state (integrator set to integral)."""
        self.integral = float(integral)
        self.output_unlimited = 0.0
        self.saturated = False

    def update(self, error: float, out_min: float | None = None,
               out_max: float | None = None) -> float:
        """One sample: return the limited output for error (per unit)."""
        lo = self.out_min if out_min is None else out_min
        hi = self.out_max if out_max is None else out_max
        out, self.integral, self.output_unlimited, self.saturated = _pi_update(
            self.kp, self.ki, lo, hi, self.integral, error)
        return out
