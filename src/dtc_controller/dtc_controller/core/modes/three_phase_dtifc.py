"""Direct torque and indirect flux control of a BLDC motor, three-phase conduction (000 ch. V).

``three_phase_dtifc``: six switches, sensorless (default) or encoder angle; Hu-Wu integrator limited
to the table's rotor-flux amplitude (000 Fig. 5.3), rotor angle by eq. (5.38), torque by eq.
(5.32), torque and d-current hysteresis (i_d* < 0: field weakening), 000 Table VI (corrected).
Start-up locks the rotor at ``three_phase.initial_angle``. Details: docs/models.md "Three-phase
DTIFC mode".
"""
from __future__ import annotations

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

    def configure(self, params) -> None:
        """The three-phase parameters, then i_d* [A] and the d-current comparator's band [A]."""
        super().configure(params)
        self._prm[K.P_ID_REF] = params['dtifc.d_current_reference']
        self._prm[K.P_FLUX_BAND] = params['dtifc.d_current_band']
