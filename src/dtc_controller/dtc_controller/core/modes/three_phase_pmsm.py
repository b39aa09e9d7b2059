"""Classical three-phase DTC (000 ch. I, Table I corrected; 001 eqs. 8-16) and the shared three-phase pipeline.

:class:`ThreePhaseBase` holds what the three-phase modes share per sample:
currents -> alpha/beta, the applied voltage of the previous sample (plus the
inverter voltage-drop correction), stator flux by a voltage or the current model,
rotor angle and speed, torque reference. :class:`ThreePhasePmsmMode`
(``three_phase_pmsm``): torque by 001 eq. (10) (000 eq. 1.25 prints the opposite
sign), two-level torque and flux hysteresis and 000 Table I as derived in
:mod:`three_phase_tables`. In full: docs/models.md "Classical three-phase DTC".
"""
from __future__ import annotations

import math

import numpy as np

from ..backemf_table import BackEmfTable
from ..line_to_line import DqBackEmf
from ..status import NAN, DtcStatusSample
from ..stator_flux_estimators import INTEGRATORS, CurrentModelFlux, make_voltage_model
from ..three_phase_tables import six_switch_sector, six_switch_table
from ..voltage_drop_compensation import SCHEMES, VoltageDropCompensation
from . import three_phase_kernel as K
from .regulation import DtcMode

DEFAULT_CUTOFF = {'low_pass': 5.0, 'hu_wu': 20.0, 'pure': 0.0}
"""rad/s: 001 uses a 5 rad/s low-pass integrator, 000 ch. V a 20 rad/s Hu-Wu integrator."""


class ThreePhaseBase(DtcMode):
    """Shared state and per-sample helpers; subclasses set name, topology, defaults and ``step``."""

    default_integrator = 'pure'
    default_position = 'encoder'
    table_required = False
    sectors = 6
    dq_torque = False
    """Torque by 000 eq. (5.32) from k_d, k_q (DTIFC) instead of 001 eq. (10), with i_d hysteresis."""
    needs_table_hint = 'needs a back-EMF table (backemf_table_path) or three_phase.pm_flux > 0'

    @classmethod
    def needs_table(cls, params: dict) -> bool:
        return cls.table_required or float(params['three_phase.pm_flux']) <= 0.0

    def __init__(self, params: dict, backemf: BackEmfTable | None) -> None:
        super().__init__(params, backemf)
        self.dq = DqBackEmf(backemf) if backemf is not None else None
        psi_m = float(params['three_phase.pm_flux'])
        self.psi_m = psi_m
        self.sample_period = float(params['sample_period'])
        self.resistance = float(params['motor.resistance'])
        self.rotor_flux_fn = self.dq.rotor_flux if self.dq is not None else self._sine_rotor_flux
        self.rotor_flux_amplitude = self.dq.rotor_flux_max if self.dq is not None else psi_m

        # ---- estimator
        self.current_model = params['three_phase.flux_model'] == 'current'
        kind = params['three_phase.integrator']
        self.integrator = self.default_integrator if kind == 'auto' else kind
        cutoff = float(params['three_phase.integrator_cutoff']) or DEFAULT_CUTOFF[self.integrator]
        self.cutoff = cutoff
        limit = float(params['three_phase.flux_limit']) or self.rotor_flux_amplitude
        self.flux_limit = limit
        if self.current_model:
            self.flux = CurrentModelFlux(self.inductance, psi_m, self.rotor_flux_fn)
        else:
            self.flux = make_voltage_model(self.integrator, self.resistance, self.sample_period, cutoff, limit)
        pos = params['three_phase.position_source']
        pos = self.default_position if pos == 'auto' else pos
        self.sensorless = pos == 'sensorless' and not self.current_model
        self.initial_angle = float(params['three_phase.initial_angle'])
        self.init_from_rotor = params['estimation.initial_flux'] == 'backemf_table'
        self._speed_gain = 1.0 - math.exp(-float(params['three_phase.speed_filter_cutoff']) * self.sample_period)

        # ---- inverter voltage model
        self.compensation = VoltageDropCompensation(self.midpoint_phase)

        self.tables = {r: self.make_table(r) for r in (1, -1)}
        self.omega_e = 0.0
        # the compiled kernel's arrays (three_phase_kernel)
        (self.vectors, self._tab, self._coef, self._legs, self._upper,
         self._select_tables) = K.mode_arrays(self.tables, self.midpoint_phase, self.dq)
        self._st = np.zeros(K.S_SIZE)
        self._st[[K.S_TAU, K.S_PHI]] = 1.0    # comparators start at +1
        self._out = np.zeros(K.O_SIZE)
        prm = self._prm = np.zeros(K.P_SIZE)
        prm[K.P_L], prm[K.P_POLES], prm[K.P_R], prm[K.P_TS] = (self.inductance, self.pole_pairs,
                                                                 self.resistance, self.sample_period)
        prm[K.P_PSI_M], prm[K.P_ROTOR_TABLE] = psi_m, self.dq is not None
        if self.dq is not None:
            prm[K.P_SCALE], prm[K.P_POINTS] = backemf._scale, backemf.points
        prm[K.P_CURRENT_MODEL], prm[K.P_INTEGRATOR] = self.current_model, INTEGRATORS.index(self.integrator)
        prm[K.P_CUTOFF], prm[K.P_LIMIT] = cutoff, limit
        prm[K.P_LEAK] = getattr(self.flux, '_leak', 0.0)
        prm[K.P_SENSORLESS], prm[K.P_INITIAL_ANGLE] = self.sensorless, self.initial_angle
        prm[K.P_INIT_ROTOR], prm[K.P_SPEED_GAIN] = self.init_from_rotor, self._speed_gain
        prm[K.P_FOUR_SECTORS], prm[K.P_DTIFC] = self.sectors == 4, self.dq_torque
        prm[K.P_MIDPOINT] = -1 if self.midpoint_phase is None else self.midpoint_phase

    # -------------------------------------------------------------- configuration
    def make_table(self, rotation: int) -> dict:
        return six_switch_table(rotation)

    def sector_of(self, angle: float) -> int:
        return six_switch_sector(angle)

    def configure(self, params: dict) -> None:
        """References, bands, gains, rotation, compensation and device drops (from the next sample)."""
        super().configure(params)
        self.flux_ref_from_table = (params['flux_control.reference_source'] == 'backemf_table'
                                    and self.dq is not None)
        self.lpf_compensation = bool(params['three_phase.low_pass_compensation'])
        self.compensation.configure(params['voltage_drop.compensation'], params['voltage_drop.v_ce'],
                                    params['voltage_drop.v_d'], params['voltage_drop.v_f'],
                                    params['voltage_drop.r_on'])
        prm, pi, comp = self._prm, self.speed_pi, self.compensation
        prm[K.P_FLUX_REF_TABLE], prm[K.P_LPF_COMP] = self.flux_ref_from_table, self.lpf_compensation
        prm[K.P_SCHEME] = SCHEMES.index(comp.scheme)
        prm[K.P_V_CE], prm[K.P_V_D], prm[K.P_V_F], prm[K.P_R_ON] = comp.v_ce, comp.v_d, comp.v_f, comp.r_on
        prm[K.P_FLUX_REF], prm[K.P_ROTATION] = self.flux_reference, self.rotation
        prm[K.P_TORQUE_REF], prm[K.P_SPEED_LOOP] = self.torque_reference, self.speed_loop
        prm[K.P_SPEED_REF], prm[K.P_TORQUE_BAND] = self.speed_reference, self.torque_hyst.band
        prm[K.P_PHI_BAND] = self.flux_hyst.band
        prm[K.P_KP], prm[K.P_KI], prm[K.P_EVERY_N], prm[K.P_TORQUE_LIMIT] = (
            pi.kp, pi.ki, pi.every_n, pi.torque_limit)
        lim = pi.torque_limit
        self._st[K.S_PI_INTEGRAL] = max(-lim, min(lim, float(self._st[K.S_PI_INTEGRAL])))
        self._select_now = self._select_tables[self.rotation]

    # -------------------------------------------------------------- per sample
    def _sine_rotor_flux(self, theta: float) -> tuple[float, float]:
        """001 eqs. (8)-(9) rotor part: psi_m (cos theta, sin theta) [Wb]."""
        return self.psi_m * math.cos(theta), self.psi_m * math.sin(theta)

    def step(self, s):
        """One sample: DriveSample -> (switch tuple, DtcStatusSample), by the compiled
        :func:`three_phase_kernel.three_phase_step` (the pipeline of the module doc)."""
        i_a, i_b, i_c, i_al, i_be, theta_enc, v_dc, v_mid = self.measure(s)
        K.three_phase_step(self._prm, self._st, self._tab, self._coef, self._legs, self._upper,
                           self._select_now, i_a, i_b, i_c, i_al, i_be, theta_enc, v_dc, v_mid,
                           s.mechanical_speed, self._out)
        status = self.status_of(s.step, self.rotation, self._out.tolist(), theta_enc, s.mechanical_speed)
        self.after_fused()
        return status.switch_on, status

    def status_of(self, step: int, rotation: int, out: list, theta_enc: float,
                  speed_m: float) -> DtcStatusSample:
        """The DtcStatusSample of one kernel output (three_phase_kernel O_*) and the measured speed."""
        (vector, t_ref, speed_ref, torque, psi_al, psi_be, psi_mag, flux_ref, id_ref, i_d, i_q, theta,
         w_e, sector, tau, phi, d_state) = out
        vec = self.vectors[int(vector)]
        return DtcStatusSample(
            step, self.name, rotation, speed_ref, speed_m, t_ref, torque, NAN, NAN,
            psi_al, psi_be, psi_mag, flux_ref, id_ref, i_d, i_q, theta, w_e, int(sector), int(tau),
            int(phi), int(d_state), vec.index, vec.switch_on)

    # status field of each kernel output column (DtcMode.status_columns)
    STATUS_COLUMNS = ('vector', 'torque_reference', 'speed_reference', 'torque_estimate', 'flux_alpha',
                      'flux_beta', 'flux_magnitude', 'flux_reference', 'd_current_reference',
                      'd_current', 'q_current', 'rotor_angle_estimate', 'speed_estimate', 'sector',
                      'torque_hysteresis', 'flux_hysteresis', 'd_current_hysteresis')

    def fused_arrays(self) -> tuple:
        """(kind 3, prm, st, tab, coef, legs, select, split_select, upper) for a fused loop."""
        return 3, self._prm, self._st, self._tab, self._coef, self._legs, self._select_now, None, self._upper

    def after_fused(self) -> None:
        """The Python-side memory of the last sample, from the kernel's state (once started)."""
        if self._st[K.S_STARTED]:
            self._started = True
            self._prev_switch = self.vectors[int(self._st[K.S_PREV_VECTOR])].switch_on
            self.omega_e = float(self._st[K.S_OMEGA_E])


class ThreePhasePmsmMode(ThreePhaseBase):
    """``three_phase_pmsm``: six-switch classical DTC, torque + flux hysteresis, 000 Table I (corrected)."""

    name = 'three_phase_pmsm'
    topology = 6
    midpoint_phase = None
    default_integrator = 'pure'
    default_position = 'encoder'
