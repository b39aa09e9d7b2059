"""Shared per-sample pipeline of the two-phase BLDC DTC modes (000 ch. II and IV).

Per sample k: phase currents (one missing sensor reconstructed), alpha/beta
currents, rotor angle from the encoder, applied voltage of sample k-1 from
its switch state (:class:`InverterVoltageModel`), voltage-model flux
(eqs. 1.22-1.23), torque (eq. 2.16/4.1), torque reference (parameter or
speed PI), sector, hysteresis, table lookup. Scalar Python only.
"""
from __future__ import annotations

import math

from drive_common.signals import TWO_PI

from ..backemf_table import BackEmfTable
from ..flux_estimator import InverterVoltageModel, VoltageModelFluxEstimator
from ..status import NAN, DtcStatusSample
from ..switching_tables import SECTOR_WIDTH, derive_flux_table
from ..torque_estimator import TorqueEstimator
from .regulation import DtcMode

_HALF = 0.5 * SECTOR_WIDTH


class TwoPhaseModeBase(DtcMode):
    """Common state and pipeline; subclasses set name, topology, vectors and override _select."""

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

    # -------------------------------------------------------------- configuration
    def make_vectors(self):
        raise NotImplementedError

    def configure(self, params: dict) -> None:
        """References, bands, gains, rotation, flux-control switch (act from the next sample)."""
        super().configure(params)
        self.flux_control = bool(params['flux_control.enabled'])
        self.flux_ref_from_table = params['flux_control.reference_source'] == 'backemf_table'

    # -------------------------------------------------------------- per sample
    def _select(self, sector: int, phi: int, tau: int, theta: float, i_a: float, i_b: float,
                t_ref: float):
        """Return (vector, phase_a_torque, phase_b_torque); subclasses add special sectors."""
        return self.table_now[(sector, phi, tau)], NAN, NAN

    def step(self, s):
        i_a, i_b, i_c, i_al, i_be, theta, v_dc, v_mid = self.measure(s)
        tab = self.table

        # ---- stator flux, eqs. (1.22)-(1.23)
        flux = self.flux
        if not self._started:
            if self.init_from_table:
                pr_al, pr_be = tab.rotor_flux(theta)
                flux.reset(pr_al + self.inductance * i_al, pr_be + self.inductance * i_be)
            flux.update(0.0, 0.0, i_al, i_be)
        else:
            emf = None
            if self.open_emf:
                w = self.pole_pairs * s.mechanical_speed
                k_a, k_b, k_c = tab.k_abc(theta)
                emf = (w * k_a, w * k_b, w * k_c)
            v_al, v_be = self.vmodel.voltage(self._prev_switch, self._prev_vdc, self._prev_vmid,
                                             self._prev_i, emf)
            flux.update(v_al, v_be, i_al, i_be)
        psi_al, psi_be = flux.psi_alpha, flux.psi_beta
        psi_mag = math.sqrt(psi_al * psi_al + psi_be * psi_be)

        # ---- torque, eq. (2.16)/(4.1)
        torque = self.torque_est.torque(theta, i_al, i_be)

        # ---- torque reference
        t_ref, speed_ref = self.torque_reference_now(s.mechanical_speed)

        # ---- sector
        ang = math.atan2(psi_be, psi_al) if self.flux_sector else theta
        sector = int(((ang + _HALF) % TWO_PI) // SECTOR_WIDTH) % 6 + 1

        # ---- hysteresis
        rot = self.rotation
        tau = self.torque_hyst.update(rot * (t_ref - torque))
        if self.flux_control:
            flux_ref = tab.rotor_flux_magnitude(theta) if self.flux_ref_from_table else self.flux_reference
            phi = self.flux_hyst.update(flux_ref - psi_mag)
        else:
            flux_ref = NAN
            phi = 0
        vec, t_a, t_b = self._select(sector, phi, tau, theta, i_a, i_b, t_ref)
        sw = vec.switch_on
        self.remember(sw, v_dc, v_mid, i_a, i_b, i_c)

        c = math.cos(theta)
        sn = math.sin(theta)
        status = DtcStatusSample(
            s.step, self.name, rot, speed_ref, s.mechanical_speed, t_ref, torque, t_a, t_b,
            psi_al, psi_be, psi_mag, flux_ref, NAN, i_al * c + i_be * sn, -i_al * sn + i_be * c,
            theta, NAN, sector, tau, phi, 0, vec.index, sw)
        return sw, status
