"""Direct torque and indirect flux control of a BLDC motor, three-phase conduction (000 ch. V).

``three_phase_dtifc``, six switches, sensorless (default) or encoder variant
(``three_phase.position_source``). Per sample: stator flux by the Hu-Wu
integrator limited to the rotor-flux amplitude of the back-EMF table (000 Fig.
5.3); rotor angle by eq. (5.38) (or the encoder) and its filtered derivative;
i_d, i_q by Park, torque by eq. (5.32); torque and d-current hysteresis (i_d* < 0
for field weakening); the sector of the estimated flux and 000 Table VI
(corrected, derived). Start-up locks the rotor at ``three_phase.initial_angle``
with the matching stator flux. Details: docs/models.md "Three-phase DTIFC mode".
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
