"""Classical three-phase DTC (000 ch. I; 001), the shared three-phase pipeline and the FSTP mode.

:class:`ThreePhaseBase`: currents -> alpha/beta, applied voltage of the previous sample (plus the
inverter voltage-drop correction), stator flux by a voltage or the current model, rotor angle and
speed, torque reference. ``three_phase_pmsm``: torque by 001 eq. (10) (000 eq. 1.25 prints the
opposite sign), torque and flux hysteresis, 000 Table I as derived in :mod:`three_phase_tables`.
``three_phase_four_switch`` (001): phase a on the split-capacitor midpoint, the four vectors,
four 90-deg sectors and Table II; low-pass integrator (w_c = 5 rad/s, as 001's experiment) and
the voltage-drop compensation none / simple / proposed. In full: docs/models.md "Classical
three-phase DTC".
"""
from __future__ import annotations

from ..backemf_table import BackEmfTable
from ..line_to_line import DqBackEmf
from ..status import NAN, DtcStatusSample
from ..stator_flux_estimators import INTEGRATORS, leak
from ..three_phase_tables import four_switch_table, six_switch_table
from ..voltage_drop_compensation import SCHEMES
from . import three_phase_kernel as K
from .regulation import DtcMode

DEFAULT_CUTOFF = {'low_pass': 5.0, 'hu_wu': 20.0, 'pure': 0.0}
"""rad/s: 001 uses a 5 rad/s low-pass integrator, 000 ch. V a 20 rad/s Hu-Wu integrator."""


class ThreePhaseBase(DtcMode):
    """Shared state and per-sample helpers; subclasses set name, topology, defaults and the table."""

    kernel = K
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
        sample_period = float(params['sample_period'])
        self.current_model = params['three_phase.flux_model'] == 'current'
        kind = params['three_phase.integrator']
        self.integrator = self.default_integrator if kind == 'auto' else kind
        self.cutoff = float(params['three_phase.integrator_cutoff']) or DEFAULT_CUTOFF[self.integrator]
        self.flux_limit = (float(params['three_phase.flux_limit'])
                           or (self.dq.rotor_flux_max if self.dq is not None else psi_m))
        pos = params['three_phase.position_source']
        pos = self.default_position if pos == 'auto' else pos
        self.sensorless = pos == 'sensorless' and not self.current_model

        self.tables = {r: self.make_table(r) for r in (1, -1)}
        (self.vectors, self._tab, self._coef, self._legs, self._upper,
         self.select_tables) = K.mode_arrays(self.tables, self.dq)
        prm = self._prm
        prm[K.P_PSI_M], prm[K.P_ROTOR_TABLE] = psi_m, self.dq is not None
        if self.dq is not None:
            prm[K.P_SCALE], prm[K.P_POINTS] = backemf._scale, backemf.points
        prm[K.P_CURRENT_MODEL], prm[K.P_INTEGRATOR] = self.current_model, INTEGRATORS.index(self.integrator)
        prm[K.P_CUTOFF], prm[K.P_LIMIT] = self.cutoff, self.flux_limit
        prm[K.P_LEAK] = 0.0 if self.current_model or self.integrator == 'pure' else leak(self.cutoff, sample_period)
        prm[K.P_SENSORLESS] = self.sensorless
        prm[K.P_INITIAL_ANGLE] = params['three_phase.initial_angle']
        prm[K.P_INIT_ROTOR] = params['estimation.initial_flux'] == 'backemf_table'
        prm[K.P_SPEED_GAIN] = leak(params['three_phase.speed_filter_cutoff'], sample_period)
        prm[K.P_FOUR_SECTORS], prm[K.P_DTIFC] = self.sectors == 4, self.dq_torque
        prm[K.P_MIDPOINT] = -1 if self.midpoint_phase is None else self.midpoint_phase

    def make_table(self, rotation: int) -> dict:
        return six_switch_table(rotation)

    def configure(self, params: dict) -> None:
        """References, bands, gains, rotation, compensation and device drops (from the next sample)."""
        super().configure(params)
        prm = self._prm
        prm[K.P_FLUX_REF_TABLE] = params['flux_control.reference_source'] == 'backemf_table' and self.dq is not None
        prm[K.P_LPF_COMP] = bool(params['three_phase.low_pass_compensation'])
        prm[K.P_SCHEME] = SCHEMES.index(params['voltage_drop.compensation'])
        prm[K.P_V_CE], prm[K.P_V_D] = params['voltage_drop.v_ce'], params['voltage_drop.v_d']
        prm[K.P_V_F], prm[K.P_R_ON] = params['voltage_drop.v_f'], params['voltage_drop.r_on']

    def kernel_step(self, i_a, i_b, i_c, i_al, i_be, theta, v_dc, v_mid, speed_m) -> None:
        """:func:`three_phase_kernel.three_phase_step` on this mode's arrays (the module doc's pipeline)."""
        K.three_phase_step(self._prm, self._st, self._tab, self._coef, self._legs, self._upper, self.select_now,
                           i_a, i_b, i_c, i_al, i_be, theta, v_dc, v_mid, speed_m, self._out)

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

    STATUS_COLUMNS = ('vector', 'torque_reference', 'speed_reference', 'torque_estimate', 'flux_alpha',
                      'flux_beta', 'flux_magnitude', 'flux_reference', 'd_current_reference',
                      'd_current', 'q_current', 'rotor_angle_estimate', 'speed_estimate', 'sector',
                      'torque_hysteresis', 'flux_hysteresis', 'd_current_hysteresis')

    def fused_arrays(self) -> tuple:
        """(kind 3, prm, st, tab, coef, legs, select, split_select, upper) for a fused loop."""
        return 3, self._prm, self._st, self._tab, self._coef, self._legs, self.select_now, None, self._upper


class ThreePhasePmsmMode(ThreePhaseBase):
    """``three_phase_pmsm``: six-switch classical DTC, torque + flux hysteresis, 000 Table I (corrected)."""

    name = 'three_phase_pmsm'


class ThreePhaseFourSwitchMode(ThreePhasePmsmMode):
    """``three_phase_four_switch``: 001 FSTP DTC (module doc); gates SW1/SW2 are off."""

    name = 'three_phase_four_switch'
    topology = 4
    midpoint_phase = 0   # phase a (001 Fig. 1b)
    default_integrator = 'low_pass'
    sectors = 4

    def make_table(self, rotation: int) -> dict:
        return four_switch_table(rotation, self.midpoint_phase)
