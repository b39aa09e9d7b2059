"""The base of every DTC mode: its life cycle and what all modes regulate alike.

Life cycle (docs/architecture.md "DTC modes"): :meth:`DtcMode.create` builds the
mode (``cls(params, backemf)``: the subclass sets up its estimators and tables
after ``super().__init__``) and then calls :meth:`DtcMode.configure`, which sets
everything a runtime parameter change may alter; the controller calls
``configure`` again for each runtime change (it acts from the next sample).

Shared regulation: torque reference T* (parameter, or the speed PI's output when
``speed_loop.enabled``), flux reference, rotation (selects the switching table
``table_now`` of ``self.tables``), two-level torque / flux comparators with
half-width bands, the speed PI, the measurement of a sample (currents with one
missing sensor reconstructed, Clarke, encoder angle) and the memory of the
applied switch state for the next sample's voltage model.
"""
from __future__ import annotations

import numpy as np

from drive_common.compiled import njit
from drive_common.signals import TWO_PI, clarke

from ..hysteresis import TwoLevelHysteresis
from ..speed_loop import SpeedPI
from ..status import NAN, DtcStatusSample

_ALL_OFF = (False,) * 6


@njit
def reconstruct_currents(i_a: float, i_b: float, i_c: float) -> tuple[float, float, float]:
    """Phase currents [A] with at most one NaN (missing sensor) filled from i_a + i_b + i_c = 0.

    Raises ValueError when two or more currents are missing.
    """
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
    """Base of the mode classes; a mode sets ``name``, ``topology``, ``tables`` {rotation: table}
    and ``step(sample) -> (switch_on, DtcStatusSample)``."""

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
        self.torque_hyst = TwoLevelHysteresis(params['torque_band'])
        self.flux_hyst = TwoLevelHysteresis(params['flux_band'])
        self.speed_pi = SpeedPI(params['speed_loop.kp'], params['speed_loop.ki'],
                                params['speed_loop.period_samples'], params['sample_period'],
                                params['speed_loop.torque_limit'])
        self._started = False
        self._prev_switch = _ALL_OFF
        self._prev_vdc = 0.0
        self._prev_vmid = 0.0
        self._prev_i = (0.0, 0.0, 0.0)
        self._speed_m = 0.0

    @classmethod
    def create(cls, params: dict, backemf) -> 'DtcMode':
        """Build the mode, then configure it from the same snapshot."""
        mode = cls(params, backemf)
        mode.configure(params)
        return mode

    def configure(self, params: dict) -> None:
        """Rotation and its table, torque / flux references and bands, speed loop and PI gains."""
        self.rotation = int(params['rotation'])
        self.table_now = self.tables[self.rotation]
        self.torque_reference = float(params['torque_reference'])
        self.torque_hyst.band = float(params['torque_band'])
        self.flux_hyst.band = float(params['flux_band'])
        self.flux_reference = float(params['flux_reference'])
        self.speed_loop = bool(params['speed_loop.enabled'])
        self.speed_reference = float(params['speed_reference'])
        self.speed_pi.set_gains(params['speed_loop.kp'], params['speed_loop.ki'],
                                params['speed_loop.period_samples'], params['speed_loop.torque_limit'])

    STATUS_COLUMNS: tuple = ()     # per mode: the status field of each kernel output column
    _INTEGER_FIELDS = frozenset({'vector', 'sector', 'torque_hysteresis', 'flux_hysteresis',
                                 'd_current_hysteresis'})

    def status_columns(self, step, rotation: int, out, theta, speed_m) -> dict:
        """The mode's ``status_of`` over n samples at once, as :meth:`DtcStatusSample.columns`:
        out (n, O_SIZE) kernel outputs named by STATUS_COLUMNS; step, theta (encoder angle, the
        rotor angle estimate unless out has one), speed_m (n,); fields not in out: NaN or 0."""
        values = dict(phase_a_torque_estimate=NAN, phase_b_torque_estimate=NAN,
                      d_current_reference=NAN, rotor_angle_estimate=theta, speed_estimate=NAN,
                      d_current_hysteresis=0)
        for name, column in zip(self.STATUS_COLUMNS, out.T):
            values[name] = column.astype(np.int64) if name in self._INTEGER_FIELDS else column
        vector = values.pop('vector')
        return DtcStatusSample.columns(len(step), self.vectors, vector, step=step, rotation=rotation,
                                       speed_measured=speed_m, **values)

    def measure(self, s):
        """(i_a, i_b, i_c, i_alpha, i_beta, encoder angle, v_dc, v_mid) of a DriveSample (:func:`measure_values`)."""
        i_a, i_b, i_c = s.phase_current
        self._speed_m = s.mechanical_speed
        return measure_values(i_a, i_b, i_c, s.encoder_angle, self.encoder_offset, s.dc_link_voltage,
                              s.midpoint_voltage)

    def remember(self, switch_on, v_dc, v_mid, i_a, i_b, i_c) -> None:
        """The applied switch state and the sample's measurements, for the next sample's voltage model."""
        self._started = True
        self._prev_switch = switch_on
        self._prev_vdc = v_dc
        self._prev_vmid = v_mid
        self._prev_i = (i_a, i_b, i_c)
