"""Classical three-phase DTC (000 ch. I, Table I corrected; 001 eqs. 8-16) and the shared three-phase pipeline.

:class:`ThreePhaseBase` holds what the three three-phase modes share, per sample k:
phase currents (one missing sensor reconstructed) -> alpha/beta (amplitude-invariant
Clarke); applied voltage of sample k-1 from its switch state, the measured DC link
and midpoint (:func:`vectors.voltage_coefficients`, cached per switch state) plus the
inverter voltage-drop correction (:mod:`voltage_drop_compensation`); stator flux by
a voltage model (pure 000 eqs. 1.22-1.23, low-pass 001, Hu-Wu 000 Fig. 5.3) or the
current model (001 eqs. 8-9); rotor angle from the encoder or eq. (5.38); electrical
speed (encoder, or the filtered derivative of the estimated angle); torque reference
(parameter or speed PI).

:class:`ThreePhasePmsmMode` (``three_phase_pmsm``, six switches): torque by 001 eq. (10)
T = 3/2 p (psi_alpha i_beta - psi_beta i_alpha) (000 eq. 1.25 prints the opposite sign:
typo), flux magnitude/angle by eqs. (1.24)/(11)-(12), two-level torque and flux
hysteresis (eqs. 1.17-1.20 / 13-14 with -1 for "0"), sector theta(1..6) of the
stator flux, 000 Table I as derived in :mod:`three_phase_tables`.
"""
from __future__ import annotations

import math

from drive_common.signals import TWO_PI

from ..backemf_table import BackEmfTable
from ..line_to_line import DqBackEmf
from ..status import NAN, DtcStatusSample
from ..stator_flux_estimators import CurrentModelFlux, compensate_low_pass, make_voltage_model
from ..three_phase_tables import six_switch_sector, six_switch_table
from ..vectors import leg_states, voltage_coefficients
from ..voltage_drop_compensation import VoltageDropCompensation
from .regulation import DtcMode

DEFAULT_CUTOFF = {'low_pass': 5.0, 'hu_wu': 20.0, 'pure': 0.0}
"""rad/s: 001 uses a 5 rad/s low-pass integrator, 000 ch. V a 20 rad/s Hu-Wu integrator."""


class ThreePhaseBase(DtcMode):
    """Shared state and per-sample helpers; subclasses set name, topology, defaults and ``step``."""

    default_integrator = 'pure'
    default_position = 'encoder'
    table_required = False
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
        self._coeffs: dict = {}

        self.tables = {r: self.make_table(r) for r in (1, -1)}
        self._prev_theta = 0.0
        self.omega_e = 0.0

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

    # -------------------------------------------------------------- helpers
    def _sine_rotor_flux(self, theta: float) -> tuple[float, float]:
        """001 eqs. (8)-(9) rotor part: psi_m (cos theta, sin theta) [Wb]."""
        return self.psi_m * math.cos(theta), self.psi_m * math.sin(theta)

    def _coefficients(self, switch_on: tuple) -> tuple:
        c = self._coeffs.get(switch_on)
        if c is None:
            a_dc, a_mid, b_dc, b_mid, _ = voltage_coefficients(leg_states(switch_on, self.midpoint_phase))
            c = self._coeffs[switch_on] = (a_dc, a_mid, b_dc, b_mid)
        return c

    def applied_voltage(self, switch_on: tuple, v_dc: float, v_mid: float, currents: tuple) -> tuple[float, float]:
        """alpha/beta voltage [V] over a sample: ideal vector from the circuit + drop correction."""
        a_dc, a_mid, b_dc, b_mid = self._coefficients(switch_on)
        v_al = a_dc * v_dc + a_mid * v_mid
        v_be = b_dc * v_dc + b_mid * v_mid
        if self.compensation.scheme != 'none':
            d_al, d_be = self.compensation.correction(switch_on, currents)
            v_al += d_al
            v_be += d_be
        return v_al, v_be

    def estimate_flux(self, i_a, i_b, i_c, i_al, i_be, theta_enc, v_dc, v_mid) -> tuple[float, float]:
        """Stator flux (psi_alpha, psi_beta) [Wb] at sample k (module doc)."""
        flux = self.flux
        if self.current_model:
            return flux.update(theta_enc, i_al, i_be)
        if not self._started:
            theta0 = self.initial_angle if self.sensorless else theta_enc
            if self.init_from_rotor:
                r_al, r_be = self.rotor_flux_fn(theta0)
                p_al, p_be = r_al + self.inductance * i_al, r_be + self.inductance * i_be
                w0 = 0.0 if self.sensorless else self.pole_pairs * self._speed_m
                if self.integrator == 'low_pass' and self.lpf_compensation and abs(w0) > 0.5 * self.cutoff:
                    # start the LPF on its periodic solution y = psi / (1 - j w_c/w_e): no slow transient
                    r = self.cutoff / w0
                    p_al, p_be = (p_al - r * p_be) / (1.0 + r * r), (p_be + r * p_al) / (1.0 + r * r)
                flux.reset(p_al, p_be)
            else:
                flux.reset(0.0, 0.0)
            flux.update(0.0, 0.0, i_al, i_be)
            self._prev_theta = theta0
            return flux.psi_alpha, flux.psi_beta
        pi = self._prev_i
        v_al, v_be = self.applied_voltage(self._prev_switch, self._prev_vdc, self._prev_vmid,
                                          (0.5 * (pi[0] + i_a), 0.5 * (pi[1] + i_b), 0.5 * (pi[2] + i_c)))
        return flux.update(v_al, v_be, i_al, i_be)

    def angle_and_speed(self, psi_al, psi_be, i_al, i_be, theta_enc, speed_m) -> tuple[float, float]:
        """(rotor angle [rad], electrical speed [rad/s]): encoder, or eq. (5.38) + filtered derivative."""
        if not self.sensorless:
            self.omega_e = self.pole_pairs * speed_m
            return theta_enc, self.omega_e
        L = self.inductance
        theta = math.atan2(psi_be - L * i_be, psi_al - L * i_al) % TWO_PI
        if self._started:
            d = theta - self._prev_theta
            if d > math.pi:
                d -= TWO_PI
            elif d < -math.pi:
                d += TWO_PI
            self.omega_e += self._speed_gain * (d / self.sample_period - self.omega_e)
        self._prev_theta = theta
        return theta, self.omega_e


class ThreePhasePmsmMode(ThreePhaseBase):
    """``three_phase_pmsm``: six-switch classical DTC, torque + flux hysteresis, 000 Table I (corrected)."""

    name = 'three_phase_pmsm'
    topology = 6
    midpoint_phase = None
    default_integrator = 'pure'
    default_position = 'encoder'

    def step(self, s):
        """One sample: DriveSample -> (switch tuple, DtcStatusSample)."""
        i_a, i_b, i_c, i_al, i_be, theta_enc, v_dc, v_mid = self.measure(s)
        psi_al, psi_be = self.estimate_flux(i_a, i_b, i_c, i_al, i_be, theta_enc, v_dc, v_mid)
        theta, w_e = self.angle_and_speed(psi_al, psi_be, i_al, i_be, theta_enc, s.mechanical_speed)
        if self.lpf_compensation and self.integrator == 'low_pass' and not self.current_model:
            psi_al, psi_be = compensate_low_pass(psi_al, psi_be, w_e, self.cutoff, 0.5 * self.cutoff)
        psi_mag = math.sqrt(psi_al * psi_al + psi_be * psi_be)
        # 001 eq. (10)
        torque = 1.5 * self.pole_pairs * (psi_al * i_be - psi_be * i_al)
        speed_m = w_e / self.pole_pairs if self.sensorless else s.mechanical_speed
        t_ref, speed_ref = self.torque_reference_now(speed_m)
        if self.flux_ref_from_table:
            r_al, r_be = self.rotor_flux_fn(theta)
            flux_ref = math.sqrt(r_al * r_al + r_be * r_be)
        else:
            flux_ref = self.flux_reference
        rot = self.rotation
        tau = self.torque_hyst.update(rot * (t_ref - torque))
        phi = self.flux_hyst.update(flux_ref - psi_mag)
        sector = self.sector_of(math.atan2(psi_be, psi_al))
        vec = self.table_now[(sector, phi, tau)]
        sw = vec.switch_on
        self.remember(sw, v_dc, v_mid, i_a, i_b, i_c)
        c, sn = math.cos(theta), math.sin(theta)
        status = DtcStatusSample(
            s.step, self.name, rot, speed_ref, s.mechanical_speed, t_ref, torque, NAN, NAN,
            psi_al, psi_be, psi_mag, flux_ref, NAN, i_al * c + i_be * sn, -i_al * sn + i_be * c,
            theta, w_e if self.sensorless else NAN, sector, tau, phi, 0, vec.index, sw)
        return sw, status
