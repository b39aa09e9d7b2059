"""The base of every DTC mode: its life cycle and what all modes regulate alike.

:meth:`DtcMode.create` builds the mode (``cls(params, backemf)``) and calls
:meth:`DtcMode.configure`, which sets everything a runtime parameter may change; the controller
calls ``configure`` again for each runtime change (docs/architecture.md "DTC modes"). Shared here:
the measurement of a sample and the kernel's arrays with the torque reference (parameter or speed
PI), flux reference, rotation, comparator bands and speed PI gains.
"""
from __future__ import annotations

import numpy as np

from drive_common.compiled import njit
from drive_common.signals import TWO_PI, clarke

from ..status import NAN, DtcStatusSample


@njit
def reconstruct_currents(i_a: float, i_b: float, i_c: float) -> tuple[float, float, float]:
    """Phase currents [A] with at most one NaN (missing sensor) filled from i_a + i_b + i_c = 0;
    ValueError when two or more are missing."""
    if i_a == i_a and i_b == i_b and i_c == i_c:  # fast path: no NaN
        return i_a, i_b, i_c
    if i_a != i_a:
        if i_b != i_b or i_c != i_c:
            raise ValueError('at least two phase currents are NaN: cannot reconstruct')
        return -i_b - i_c, i_b, i_c
    if i_b != i_b:
        if i_c != i_c:
            raise ValueError('at least two phase currents are NaN: cannot reconstruct')
        return i_a, -i_a - i_c, i_c
    return i_a, i_b, -i_a - i_b


_clarke = njit(clarke)


@njit
def measure_values(i_a, i_b, i_c, encoder_angle, encoder_offset, v_dc, v_mid):
    """(i_a, i_b, i_c, i_alpha, i_beta, encoder angle, v_dc, v_mid) of one measurement: one missing
    current reconstructed, Clarke, the encoder offset added, a missing midpoint taken as v_dc / 2."""
    if not (i_a == i_a and i_b == i_b and i_c == i_c):
        i_a, i_b, i_c = reconstruct_currents(i_a, i_b, i_c)
    theta = encoder_angle
    if encoder_offset:
        theta = (theta + encoder_offset) % TWO_PI
    if v_mid != v_mid:
        v_mid = 0.5 * v_dc
    i_al, i_be = _clarke(i_a, i_b, i_c)
    return i_a, i_b, i_c, i_al, i_be, theta, v_dc, v_mid


class DtcMode:
    """Base of the mode classes; a mode sets ``name``, ``topology``, ``kernel``, ``vectors``,
    ``select_tables`` {rotation: kernel selection table} and ``kernel_step``."""

    name = ''
    topology = 6
    midpoint_phase: int | None = None

    needs_table_hint = 'needs a back-EMF table (parameter backemf_table_path)'

    @classmethod
    def needs_table(cls, params: dict) -> bool:
        """Whether the mode cannot run on snapshot params without a back-EMF table."""
        return True

    @classmethod
    def check(cls, params: dict, backemf) -> None:
        """ValueError when the mode cannot run with this snapshot and table (what __init__ relies on)."""
        p = int(params['motor.pole_pairs'])
        if backemf is not None and backemf.pole_pairs != p:
            raise ValueError(f'{backemf.source_path}: table is for pole_pairs {backemf.pole_pairs}, '
                             f'motor.pole_pairs is {p}')
        if backemf is None and cls.needs_table(params):
            raise ValueError(f'mode {cls.name}: {cls.needs_table_hint}')

    def __init__(self, params: dict, backemf) -> None:
        self.check(params, backemf)
        self.pole_pairs = int(params['motor.pole_pairs'])
        self.table = backemf
        self.inductance = float(params['motor.inductance'])
        self.encoder_offset = float(params['estimation.encoder_offset'])
        K = self.kernel
        self._st = np.zeros(K.S_SIZE)
        self._st[[K.S_TAU, K.S_PHI]] = 1.0    # comparators start at +1
        self._out = np.zeros(K.O_SIZE)
        prm = self._prm = np.zeros(K.P_SIZE)
        prm[K.P_L], prm[K.P_POLES] = self.inductance, self.pole_pairs
        prm[K.P_R], prm[K.P_TS] = float(params['motor.resistance']), float(params['sample_period'])

    @classmethod
    def create(cls, params: dict, backemf) -> 'DtcMode':
        """Build the mode, then configure it from the same snapshot."""
        mode = cls(params, backemf)
        mode.configure(params)
        return mode

    def configure(self, params: dict) -> None:
        """Rotation, references, bands and speed PI gains (its integral kept, clamped: bumpless)."""
        self.rotation = int(params['rotation'])
        self.select_now = self.select_tables[self.rotation]
        K, prm = self.kernel, self._prm
        lim = abs(float(params['speed_loop.torque_limit']))
        prm[K.P_ROTATION], prm[K.P_TORQUE_REF] = self.rotation, float(params['torque_reference'])
        prm[K.P_SPEED_LOOP], prm[K.P_SPEED_REF] = bool(params['speed_loop.enabled']), params['speed_reference']
        prm[K.P_TORQUE_BAND], prm[K.P_FLUX_BAND] = params['torque_band'], params['flux_band']
        prm[K.P_FLUX_REF] = params['flux_reference']
        prm[K.P_KP], prm[K.P_KI] = params['speed_loop.kp'], params['speed_loop.ki']
        prm[K.P_EVERY_N], prm[K.P_TORQUE_LIMIT] = max(1, int(params['speed_loop.period_samples'])), lim
        self._st[K.S_PI_INTEGRAL] = max(-lim, min(lim, float(self._st[K.S_PI_INTEGRAL])))

    STATUS_COLUMNS: tuple = ()     # per mode: the status field of each kernel output column
    _INTEGER_FIELDS = frozenset({'vector', 'sector', 'torque_hysteresis', 'flux_hysteresis',
                                 'd_current_hysteresis'})

    def status_columns(self, step, rotation: int, out, theta, speed_m) -> dict:
        """``status_of`` over n samples as :meth:`DtcStatusSample.columns`: out (n, O_SIZE) named by
        STATUS_COLUMNS; step, theta (encoder angle), speed_m (n,); fields not in out: NaN or 0."""
        values = dict(phase_a_torque_estimate=NAN, phase_b_torque_estimate=NAN,
                      d_current_reference=NAN, rotor_angle_estimate=theta, speed_estimate=NAN,
                      d_current_hysteresis=0)
        for name, column in zip(self.STATUS_COLUMNS, out.T):
            values[name] = column.astype(np.int64) if name in self._INTEGER_FIELDS else column
        vector = values.pop('vector')
        return DtcStatusSample.columns(len(step), self.vectors, vector, step=step, rotation=rotation,
                                       speed_measured=speed_m, **values)

    def step(self, s):
        """One sample: DriveSample -> (switch tuple, DtcStatusSample), by the mode's compiled kernel."""
        i_a, i_b, i_c = s.phase_current
        i_a, i_b, i_c, i_al, i_be, theta, v_dc, v_mid = measure_values(
            i_a, i_b, i_c, s.encoder_angle, self.encoder_offset, s.dc_link_voltage, s.midpoint_voltage)
        self.kernel_step(i_a, i_b, i_c, i_al, i_be, theta, v_dc, v_mid, s.mechanical_speed)
        status = self.status_of(s.step, self.rotation, self._out.tolist(), theta, s.mechanical_speed)
        return status.switch_on, status

    def after_fused(self) -> None:
        """Called after a fused loop ran the kernel on this mode's arrays: nothing is kept outside them."""
