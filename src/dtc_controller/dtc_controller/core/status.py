"""DtcStatusSample: one field per dtc_msgs/DtcStatus field (header excluded), same names and units."""
from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

NAN = float('nan')


@dataclass(slots=True)
class DtcStatusSample:
    """Controller internals for one sample (see DtcStatus.msg); NaN / 0 where a mode has no value."""

    step: int
    mode: str
    rotation: int                    # +1 CCW, -1 CW
    speed_reference: float           # rad/s mechanical, NaN without speed loop
    speed_measured: float            # rad/s mechanical
    torque_reference: float          # N m
    torque_estimate: float           # N m
    phase_a_torque_estimate: float   # N m (four-switch sectors II/V), else NaN
    phase_b_torque_estimate: float   # N m
    flux_alpha: float                # Wb
    flux_beta: float                 # Wb
    flux_magnitude: float            # Wb
    flux_reference: float            # Wb, NaN without flux control
    d_current_reference: float       # A, NaN (DTIFC only)
    d_current: float                 # A
    q_current: float                 # A
    rotor_angle_estimate: float      # rad electrical, [0, 2 pi)
    speed_estimate: float            # rad/s electrical, NaN (sensorless modes only)
    sector: int                      # 1..6, 0 undefined
    torque_hysteresis: int           # tau
    flux_hysteresis: int             # phi
    d_current_hysteresis: int        # 0 (DTIFC only)
    voltage_vector: int              # index in the mode's vector numbering
    switch_on: tuple                 # SW1..SW6

    @classmethod
    def columns(cls, n: int, vectors, vector, **values) -> dict:
        """n statuses as float columns (scalars repeated, switch_on (n, 6), mode left out), as
        ``np.array`` over the objects gives; vector: (n,) indexes into the mode's vectors."""
        vector = np.asarray(vector).astype(np.int64)
        values['voltage_vector'] = np.array([v.index for v in vectors], dtype=float)[vector]
        values['switch_on'] = np.array([v.switch_on for v in vectors], dtype=float)[vector]
        out = {}
        for f in fields(cls):
            if f.name != 'mode':
                value = np.asarray(values[f.name], dtype=float)
                out[f.name] = np.full(n, float(value)) if value.ndim == 0 else value
        return out

    @classmethod
    def partial(cls, step: int, mode: str, **values) -> 'DtcStatusSample':
        """A status with the given fields, the others NaN / 0 / switches off: for controllers with only
        some of the DTC's internals (docs/write_your_own_controller.md)."""
        base = {f.name: NAN for f in fields(cls)}
        base.update(step=step, mode=mode, rotation=1, sector=0, torque_hysteresis=0,
                    flux_hysteresis=0, d_current_hysteresis=0, voltage_vector=0,
                    switch_on=(False,) * 6)
        base.update(values)
        return cls(**base)
