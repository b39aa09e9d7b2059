"""The two-phase BLDC DTC modes (000 ch. II and IV): their shared pipeline and the six-switch mode.

Per sample (the compiled :func:`two_phase_kernel.two_phase_step` on arrays built here): currents,
encoder angle, applied voltage of sample k-1, voltage-model flux (eqs. 1.22-1.23), torque (eq.
2.16/4.1), torque reference, sector, hysteresis and table lookup. ``two_phase_six_switch`` (000
ch. II, Table II) uses the phi = 0 row (torque hysteresis only); ``flux_control.enabled`` selects
the phi = +-1 rows by a flux comparator against eq. (2.20)'s reference ("switch state 1", kept
for the seed's comparison).
"""
from __future__ import annotations

from ..backemf_table import BackEmfTable
from ..status import NAN, DtcStatusSample
from ..switching_tables import derive_flux_table
from ..vectors import two_phase_six_switch_vectors
from . import two_phase_kernel as K
from .regulation import DtcMode


class TwoPhaseModeBase(DtcMode):
    """Common state and pipeline; subclasses set name, topology, vectors and the split-phase tables."""

    kernel = K

    def __init__(self, params: dict, backemf: BackEmfTable | None) -> None:
        super().__init__(params, backemf)
        self.vectors = self.make_vectors()
        self.tables = {r: derive_flux_table(self.vectors, r) for r in (1, -1)}
        self._tab = K.table_array(backemf)
        self._coef = K.coefficient_table()
        self._legs = K.leg_codes(self.vectors)
        self.select_tables = {r: K.selection_table(t, self.vectors) for r, t in self.tables.items()}
        self.split_select = {r: K.selection_table(t, self.vectors) for r, t in self.split_phase_tables().items()}
        self._st[[K.S_TAU_A, K.S_TAU_B]] = 1.0    # split-phase comparators start at +1 too
        prm = self._prm
        prm[K.P_TORQUE_C] = 1.5 * self.pole_pairs                        # eq. (2.16)/(4.1) in pole pairs
        prm[K.P_SCALE], prm[K.P_POINTS] = backemf._scale, backemf.points
        prm[K.P_DIODE] = params['estimation.voltage_model'] == 'diode_clamped'
        prm[K.P_THRESHOLD] = params['estimation.open_phase_current_threshold']
        prm[K.P_OPEN_EMF] = bool(params['estimation.open_phase_emf'])
        prm[K.P_FLUX_SECTOR] = params['estimation.sector_source'] == 'flux'
        prm[K.P_INIT_TABLE] = params['estimation.initial_flux'] == 'backemf_table'

    def make_vectors(self):
        return two_phase_six_switch_vectors()

    def split_phase_tables(self) -> dict:
        """{rotation: {(sector, tau_a, tau_b): vector}} of the split-phase sectors (none here)."""
        return {1: {}, -1: {}}

    def configure(self, params: dict) -> None:
        """References, bands, gains, rotation, flux-control switch (act from the next sample)."""
        super().configure(params)
        prm = self._prm
        prm[K.P_FLUX_CONTROL] = bool(params['flux_control.enabled'])
        prm[K.P_FLUX_REF_TABLE] = params['flux_control.reference_source'] == 'backemf_table'
        self.split_now = self.split_select[self.rotation]

    def kernel_step(self, i_a, i_b, i_c, i_al, i_be, theta, v_dc, v_mid, speed_m) -> None:
        """:func:`two_phase_kernel.two_phase_step` on this mode's arrays."""
        K.two_phase_step(self._prm, self._st, self._tab, self._coef, self._legs, self.select_now,
                         self.split_now, i_a, i_b, i_c, i_al, i_be, theta, v_dc, v_mid, speed_m, self._out)

    def status_of(self, step: int, rotation: int, out: list, theta: float, speed_m: float) -> DtcStatusSample:
        """The DtcStatusSample of one kernel output (two_phase_kernel O_*), measured angle and speed."""
        (vector, t_ref, speed_ref, torque, t_a, t_b, psi_al, psi_be, psi_mag, flux_ref, i_d, i_q,
         sector, tau, phi) = out
        vec = self.vectors[int(vector)]
        return DtcStatusSample(
            step, self.name, rotation, speed_ref, speed_m, t_ref, torque, t_a, t_b,
            psi_al, psi_be, psi_mag, flux_ref, NAN, i_d, i_q, theta, NAN, int(sector), int(tau),
            int(phi), 0, vec.index, vec.switch_on)

    STATUS_COLUMNS = ('vector', 'torque_reference', 'speed_reference', 'torque_estimate',
                      'phase_a_torque_estimate', 'phase_b_torque_estimate', 'flux_alpha', 'flux_beta',
                      'flux_magnitude', 'flux_reference', 'd_current', 'q_current', 'sector',
                      'torque_hysteresis', 'flux_hysteresis')

    def fused_arrays(self) -> tuple:
        """(kind 2, prm, st, tab, coef, legs, select, split_select, upper) for a fused loop."""
        return 2, self._prm, self._st, self._tab, self._coef, self._legs, self.select_now, self.split_now, None


class TwoPhaseSixSwitchMode(TwoPhaseModeBase):
    """``two_phase_six_switch``: see the module doc."""

    name = 'two_phase_six_switch'
    topology = 6
