"""Shared per-sample pipeline of the two-phase BLDC DTC modes (000 ch. II and IV).

Per sample k: phase currents (one missing sensor reconstructed), alpha/beta
currents, rotor angle from the encoder, applied voltage of sample k-1 from
its switch state (:class:`InverterVoltageModel`), voltage-model flux
(eqs. 1.22-1.23), torque (eq. 2.16/4.1), torque reference (parameter or
speed PI), sector, hysteresis, table lookup: the compiled
:func:`two_phase_kernel.two_phase_step` on arrays built here.
"""
from __future__ import annotations

import numpy as np

from ..backemf_table import BackEmfTable
from ..flux_estimator import InverterVoltageModel, VoltageModelFluxEstimator
from ..status import NAN, DtcStatusSample
from ..switching_tables import derive_flux_table
from ..torque_estimator import TorqueEstimator
from . import two_phase_kernel as K
from .regulation import DtcMode


class TwoPhaseModeBase(DtcMode):
    """Common state and pipeline; subclasses set name, topology, vectors and the split-phase tables."""

    def __init__(self, params: dict, backemf: BackEmfTable | None) -> None:
        super().__init__(params, backemf)
        self.torque_est = TorqueEstimator(backemf, self.pole_pairs)
        self.flux = VoltageModelFluxEstimator(params['motor.resistance'], params['sample_period'])
        self.vmodel = InverterVoltageModel(self.midpoint_phase, params['estimation.voltage_model'],
                                           params['estimation.open_phase_current_threshold'])
        self.open_emf = bool(params['estimation.open_phase_emf'])
        self.flux_sector = params['estimation.sector_source'] == 'flux'
        self.init_from_table = params['estimation.initial_flux'] == 'backemf_table'
        self.vectors = self.make_vectors()
        # tables for both rotations: {rotation: {(sector, phi, tau): vector}}
        self.tables = {r: derive_flux_table(self.vectors, r) for r in (1, -1)}
        # the compiled kernel's arrays (two_phase_kernel)
        self._tab = K.table_array(backemf)
        self._coef = K.coefficient_table()
        self._legs = K.leg_codes(self.vectors)
        self._select_tables = {r: K.selection_table(t, self.vectors) for r, t in self.tables.items()}
        self._split_select = {r: K.selection_table(t, self.vectors) for r, t in self.split_phase_tables().items()}
        self._st = np.zeros(K.S_SIZE)
        self._st[[K.S_TAU, K.S_PHI, K.S_TAU_A, K.S_TAU_B]] = 1.0    # comparators start at +1
        self._out = np.zeros(K.O_SIZE)
        prm = self._prm = np.zeros(K.P_SIZE)
        prm[K.P_R], prm[K.P_TS] = self.flux.resistance, self.flux.sample_period
        prm[K.P_L], prm[K.P_POLES], prm[K.P_TORQUE_C] = self.inductance, self.pole_pairs, self.torque_est._c
        prm[K.P_SCALE], prm[K.P_POINTS] = backemf._scale, backemf.points
        prm[K.P_DIODE], prm[K.P_THRESHOLD] = self.vmodel.diode, self.vmodel.threshold
        prm[K.P_OPEN_EMF], prm[K.P_FLUX_SECTOR] = self.open_emf, self.flux_sector
        prm[K.P_INIT_TABLE], prm[K.P_SAMPLE_PERIOD] = self.init_from_table, self.speed_pi.sample_period

    # -------------------------------------------------------------- configuration
    def make_vectors(self):
        raise NotImplementedError

    def split_phase_tables(self) -> dict:
        """{rotation: {(sector, tau_a, tau_b): vector}} of sectors with split-phase control (none here)."""
        return {1: {}, -1: {}}

    def split_band(self, params: dict) -> float:
        """Half-width of the split-phase comparators [N m] (unused without split sectors)."""
        return 0.0

    def configure(self, params: dict) -> None:
        """References, bands, gains, rotation, flux-control switch (act from the next sample)."""
        super().configure(params)
        self.flux_control = bool(params['flux_control.enabled'])
        self.flux_ref_from_table = params['flux_control.reference_source'] == 'backemf_table'
        prm, pi = self._prm, self.speed_pi
        prm[K.P_FLUX_CONTROL], prm[K.P_FLUX_REF_TABLE] = self.flux_control, self.flux_ref_from_table
        prm[K.P_FLUX_REF], prm[K.P_ROTATION] = self.flux_reference, self.rotation
        prm[K.P_TORQUE_REF], prm[K.P_SPEED_LOOP] = self.torque_reference, self.speed_loop
        prm[K.P_SPEED_REF], prm[K.P_TORQUE_BAND] = self.speed_reference, self.torque_hyst.band
        prm[K.P_FLUX_BAND], prm[K.P_SPLIT_BAND] = self.flux_hyst.band, self.split_band(params)
        prm[K.P_KP], prm[K.P_KI], prm[K.P_EVERY_N], prm[K.P_TORQUE_LIMIT] = (
            pi.kp, pi.ki, pi.every_n, pi.torque_limit)
        lim = pi.torque_limit
        self._st[K.S_PI_INTEGRAL] = max(-lim, min(lim, float(self._st[K.S_PI_INTEGRAL])))
        self._select_now = self._select_tables[self.rotation]
        self._split_now = self._split_select[self.rotation]

    # -------------------------------------------------------------- per sample
    def step(self, s):
        i_a, i_b, i_c, i_al, i_be, theta, v_dc, v_mid = self.measure(s)
        speed_m = s.mechanical_speed
        K.two_phase_step(self._prm, self._st, self._tab, self._coef, self._legs, self._select_now,
                         self._split_now, i_a, i_b, i_c, i_al, i_be, theta, v_dc, v_mid, speed_m,
                         self._out)
        status = self.status_of(s.step, self.rotation, self._out.tolist(), theta, speed_m)
        return status.switch_on, status

    def status_of(self, step: int, rotation: int, out: list, theta: float, speed_m: float) -> DtcStatusSample:
        """The DtcStatusSample of one kernel output (two_phase_kernel O_*), measured angle and speed."""
        (vector, t_ref, speed_ref, torque, t_a, t_b, psi_al, psi_be, psi_mag, flux_ref, i_d, i_q,
         sector, tau, phi) = out
        vec = self.vectors[int(vector)]
        return DtcStatusSample(
            step, self.name, rotation, speed_ref, speed_m, t_ref, torque, t_a, t_b,
            psi_al, psi_be, psi_mag, flux_ref, NAN, i_d, i_q, theta, NAN, int(sector), int(tau),
            int(phi), 0, vec.index, vec.switch_on)

    # status field of each kernel output column (DtcMode.status_columns)
    STATUS_COLUMNS = ('vector', 'torque_reference', 'speed_reference', 'torque_estimate',
                      'phase_a_torque_estimate', 'phase_b_torque_estimate', 'flux_alpha', 'flux_beta',
                      'flux_magnitude', 'flux_reference', 'd_current', 'q_current', 'sector',
                      'torque_hysteresis', 'flux_hysteresis')

    def fused_arrays(self) -> tuple:
        """(kind 2, prm, st, tab, coef, legs, select, split_select, upper) for a fused loop."""
        return 2, self._prm, self._st, self._tab, self._coef, self._legs, self._select_now, self._split_now, None

    def after_fused(self) -> None:
        """Nothing kept outside the kernel's arrays."""
