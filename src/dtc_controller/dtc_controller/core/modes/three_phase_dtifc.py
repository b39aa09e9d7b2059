"""Direct torque and indirect flux control of a BLDC motor, three-phase conduction (000 ch. V).

``three_phase_dtifc``, six switches, sensorless (default) or encoder variant
(``three_phase.position_source``). Per sample k:
* stator flux by the Hu-Wu modified integrator with amplitude limiter (000
  Fig. 5.3, eqs. 5.36-5.37, w_c = 20 rad/s); limit = the rotor-flux amplitude,
  max |psi_r(theta)| of the back-EMF table (for an ideal trapezoid 7 pi k_LL/36;
  the seed's 2 pi k_LL/(3 sqrt 3) is the peak-to-peak swing, see
  :func:`line_to_line.trapezoid_rotor_flux`);
* start-up: rotor locked at ``three_phase.initial_angle`` (0 = phase a) with the
  matching stator flux psi_r(theta_0) from the table (000 sec. 5.3.3), or at the
  encoder angle in the encoder variant;
* rotor angle by eq. (5.38) theta_e = atan2(psi_beta - L i_beta, psi_alpha - L i_alpha)
  (or the encoder); electrical speed = filtered derivative of that angle;
* i_d, i_q by Park at theta_e (identical to the line-to-line Park (5.15) of
  i_ba, i_ca -- :mod:`line_to_line`, tested), k_d, k_q from the table, torque by
  eq. (5.32) T = 3/2 p (k_d i_d + k_q i_q);
* torque hysteresis (tau) and d-current hysteresis (phi = +1 when i_d* - i_d > band:
  raising i_d raises |psi_s| = |L i + psi_r|, eq. 5.26), i_d* = 0 in the constant-torque
  region, negative for field weakening (000 Fig. 5.6);
* sector theta(1..6) of the estimated stator flux, 000 Table VI (corrected, derived).
"""
from __future__ import annotations

from ..hysteresis import TwoLevelHysteresis
from . import three_phase_kernel as K
from .three_phase_pmsm import ThreePhaseBase


class ThreePhaseDtifcMode(ThreePhaseBase):
    """``three_phase_dtifc``: see the module doc."""

    name = 'three_phase_dtifc'
    topology = 6
    midpoint_phase = None
    default_integrator = 'hu_wu'
    default_position = 'sensorless'
    table_required = True
    dq_torque = True

    def __init__(self, params, backemf) -> None:
        super().__init__(params, backemf)
        self.id_hyst = TwoLevelHysteresis(params['dtifc.d_current_band'])

    def configure(self, params) -> None:
        super().configure(params)
        self.id_reference = float(params['dtifc.d_current_reference'])
        self.id_hyst.band = float(params['dtifc.d_current_band'])
        self._prm[K.P_ID_REF], self._prm[K.P_PHI_BAND] = self.id_reference, self.id_hyst.band
