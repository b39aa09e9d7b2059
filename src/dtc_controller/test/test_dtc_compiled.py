"""The compiled DTC kernels give bit-identical trajectories to the same code interpreted."""
import numpy as np

from drive_common.compiled import jit_disabled
from drive_testing.compiled_parity import differing, interpreted_and_compiled, requires_jit
from dtc_controller.core.modes.two_phase_kernel import two_phase_step

pytestmark = requires_jit()

# every two-phase mode and option, and three-phase modes using the shared comparator and speed PI
DTC_SCENARIOS = ['two_phase_six_switch_torque_step', 'two_phase_six_switch_flux_control',
                 'two_phase_six_switch_nonideal_torque', 'two_phase_four_switch_torque_step',
                 'two_phase_four_switch_flux_control', 'sstp_voltage_model_no_compensation',
                 'fstp_voltage_model_proposed_compensation', 'three_phase_dtifc_sensorless']


def test_kernel_is_compiled():
    assert not jit_disabled() and hasattr(two_phase_step, 'py_func')


def test_compiled_equals_interpreted_bit_for_bit(tmp_path):
    interpreted, compiled = interpreted_and_compiled('drive_testing.compiled_parity:scenario_arrays',
                                                     [DTC_SCENARIOS, 0.02], tmp_path)
    torque = compiled['two_phase_four_switch_torque_step:dtc/status.torque_estimate']
    assert torque.size > 100 and np.ptp(torque) > 0.0          # a real, moving trajectory
    assert differing(interpreted, compiled) == []
