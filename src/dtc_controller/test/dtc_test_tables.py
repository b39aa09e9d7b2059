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


# Three-phase DTC options the shipped scenarios do not use: (mode, parameters, with the
# synthetic back-EMF table); at half time each case turns rotation and drop compensation
# and widens the bands (runtime reconfiguration).
DTC_OPTION_CASES = [
    ('three_phase_pmsm', {}, True),
    ('three_phase_pmsm', {'three_phase.pm_flux': 0.05, 'estimation.encoder_offset': 0.3}, False),
    ('three_phase_pmsm', {'three_phase.integrator': 'low_pass', 'three_phase.low_pass_compensation': True,
                          'flux_control.reference_source': 'backemf_table', 'speed_loop.enabled': True,
                          'speed_reference': 30.0}, True),
    ('three_phase_pmsm', {'three_phase.flux_model': 'current', 'three_phase.pm_flux': 0.05}, False),
    ('three_phase_pmsm', {'three_phase.integrator': 'hu_wu', 'three_phase.position_source': 'sensorless',
                          'three_phase.initial_angle': 0.4, 'estimation.initial_flux': 'zero'}, True),
    ('three_phase_four_switch', {'voltage_drop.compensation': 'proposed',
                                 'three_phase.low_pass_compensation': True}, True),
    ('three_phase_dtifc', {'speed_loop.enabled': True, 'speed_reference': 20.0}, True),
    ('three_phase_dtifc', {'three_phase.position_source': 'encoder', 'dtifc.d_current_reference': -0.5}, True),
]


def dtc_option_arrays(samples: int) -> dict:
    """Status and gate arrays of DtcCore for DTC_OPTION_CASES over synthetic measurements
    (rotating currents nudged by the applied gates, one current sensor missing now and then): 'case:field'."""
    import math
    from dataclasses import fields

    from drive_common.samples import DriveSample
    from dtc_controller.core.backemf_table import BackEmfTable
    from dtc_controller.core.controller import DtcCore
    from dtc_controller.core.status import DtcStatusSample

    th = np.arange(360) * (2 * np.pi / 360)
    table = BackEmfTable.from_phase_constants(
        *(0.0573 * np.clip(-np.sin(th - s) * 2.0, -1.0, 1.0) for s in (0, 2 * np.pi / 3, 4 * np.pi / 3)), 2)
    names = [f.name for f in fields(DtcStatusSample) if f.name not in ('mode', 'switch_on')]
    out = {}
    for n, (mode, extra, with_table) in enumerate(DTC_OPTION_CASES):
        core = DtcCore({'mode': mode, 'torque_reference': 0.5, 'motor.pole_pairs': 2, **extra},
                       table if with_table else None)
        rows, gates, nudge = [], [], 0.0
        for k in range(samples):
            if k == samples // 2:
                core.reconfigure({'rotation': -1, 'torque_band': 0.01, 'flux_band': 0.002,
                                  'voltage_drop.compensation': 'simple'})
            w = 2 * math.pi * 25.0 * k * 25e-6
            i = [3 * math.sin(w + nudge), 3 * math.sin(w - 2.1 + nudge)]
            i.append(-i[0] - i[1])
            if k % 97 == 5:
                i[k % 3] = math.nan
            sample = DriveSample(k, k * 25e-6, tuple(i), 56.57 + math.sin(w), 28.28, 0, (2 * w) % (2 * math.pi),
                                 0, 30.0 + math.cos(w))
            gate, status = core.update(sample)
            nudge += 0.002 * (sum(gate.switch_on[0::2]) - 1.5)
            rows.append([float(getattr(status, f)) for f in names])
            gates.append(gate.switch_on)
        data = np.array(rows)
        out.update({f'{n}:{f}': data[:, j] for j, f in enumerate(names)})
        out[f'{n}:switch_on'] = np.array(gates, dtype=np.int8)
    return out
