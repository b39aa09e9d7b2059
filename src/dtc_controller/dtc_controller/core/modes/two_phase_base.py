"""Shared per-sample pipeline of the two-phase BLDC DTC modes (000 ch. II and IV).

Per sample k: phase currents (one missing sensor reconstructed), alpha/beta
currents, rotor angle from the encoder, applied voltage of sample k-1 from
its switch state (:class:`InverterVoltageModel`), voltage-model flux
(eqs. 1.22-1.23), torque (eq. 2.16/4.1), torque reference (parameter or
speed PI), sector, hysteresis, table lookup. Scalar Python only.
"""
from __future__ import annotations

import math

from ..backemf_table import BackEmfTable
from ..flux_estimator import InverterVoltageModel, VoltageModelFluxEstimator
from ..status import NAN, DtcStatusSample
from ..switching_tables import SECTOR_WIDTH, derive_flux_table
from ..torque_estimator import TorqueEstimator
from ..transforms import INV_SQRT3, TWO_PI
from .regulation import DtcRegulation

_HALF = 0.5 * SECTOR_WIDTH


class TwoPhaseModeBase(DtcRegulation):
    """Common state and pipeline; subclasses set name, topology, vectors and override _select."""

    name = ''
    topology = 6
    midpoint_phase: int | None = None

    def __init__(self, params: dict, backemf: BackEmfTable | None) -> None:
        if backemf is None:
            raise ValueError(f'mode {self.name}: needs a back-EMF table (parameter backemf_table_path)')
        p = int(params['motor.pole_pairs'])
        if backemf.pole_pairs != p:
            raise ValueError(f'{backemf.source_path}: table is for pole_pairs {backemf.pole_pairs}, '
                             f'motor.pole_pairs is {p}')
        self.table = backemf
        self.pole_pairs = p
        self.inductance = float(params['motor.inductance'])
        self.torque_est = TorqueEstimator(backemf, p)
        self.flux = VoltageModelFluxEstimator(params['motor.resistance'], params['sample_period'])
        self.vmodel = InverterVoltageModel(self.midpoint_phase, params['estimation.voltage_model'],
                                           params['estimation.open_phase_current_threshold'])
        self.open_emf = bool(params['estimation.open_phase_emf'])
        self.flux_sector = params['estimation.sector_source'] == 'flux'
        self.encoder_offset = float(params['estimation.encoder_offset'])
        self.init_from_table = params['estimation.initial_flux'] == 'backemf_table'
        self.vectors = self.make_vectors()
        # tables for both rotations: {rotation: {(sector, phi, tau): vector}}
        self.tables = {r: derive_flux_table(self.vectors, r) for r in (1, -1)}
        self._build_regulators(params)
        self.apply_runtime(params)
        self._prev_switch = (False,) * 6
        self._prev_vdc = 0.0
        self._prev_vmid = 0.0
        self._prev_i = (0.0, 0.0, 0.0)
        self._started = False

    # -------------------------------------------------------------- configuration
    def make_vectors(self):
        raise NotImplementedError

    def apply_runtime(self, params: dict) -> None:
        """References, bands, gains, rotation, flux-control switch (act from the next sample)."""
        self.flux_control = bool(params['flux_control.enabled'])
        self.flux_ref_from_table = params['flux_control.reference_source'] == 'backemf_table'
        self._apply_references(params)

    # -------------------------------------------------------------- per sample
    def _select(self, sector: int, phi: int, tau: int, theta: float, i_a: float, i_b: float,
                t_ref: float):
        """Return (vector, phase_a_torque, phase_b_torque); subclasses add special sectors."""
        return self.table_now[(sector, phi, tau)], NAN, NAN

    def step(self, s):
        i_a, i_b, i_c = s.phase_current
        if not (i_a == i_a and i_b == i_b and i_c == i_c):
            from ..transforms import reconstruct_currents
            i_a, i_b, i_c = reconstruct_currents(i_a, i_b, i_c)
        i_al = (2.0 * i_a - i_b - i_c) / 3.0
        i_be = (i_b - i_c) * INV_SQRT3
        theta = s.encoder_angle
        if self.encoder_offset:
            theta = (theta + self.encoder_offset) % TWO_PI
        tab = self.table
        v_dc = s.dc_link_voltage
        v_mid = s.midpoint_voltage
        if v_mid != v_mid:
            v_mid = 0.5 * v_dc

        # ---- stator flux, eqs. (1.22)-(1.23)
        flux = self.flux
        if not self._started:
            self._started = True
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
        if self.speed_loop:
            t_ref = self.speed_pi.update(self.speed_reference, s.mechanical_speed)
            speed_ref = self.speed_reference
        else:
            t_ref = self.torque_reference
            speed_ref = NAN

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

        self._prev_switch = sw
        self._prev_vdc = v_dc
        self._prev_vmid = v_mid
        self._prev_i = (i_a, i_b, i_c)

        c = math.cos(theta)
        sn = math.sin(theta)
        status = DtcStatusSample(
            s.step, self.name, rot, speed_ref, s.mechanical_speed, t_ref, torque, t_a, t_b,
            psi_al, psi_be, psi_mag, flux_ref, NAN, i_al * c + i_be * sn, -i_al * sn + i_be * c,
            theta, NAN, sector, tau, phi, 0, vec.index, sw)
        return sw, status
