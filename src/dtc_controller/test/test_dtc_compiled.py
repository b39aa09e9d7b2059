"""The compiled DTC kernels give bit-identical trajectories to the same code interpreted."""
import numpy as np

from drive_common.compiled import jit_disabled
from drive_testing.compiled_parity import differing, interpreted_and_compiled, requires_jit
from dtc_controller.core.modes.three_phase_kernel import three_phase_step
from dtc_controller.core.modes.two_phase_kernel import two_phase_step
from dtc_test_tables import DTC_OPTION_CASES

pytestmark = requires_jit()

# every two-phase mode and option; every three-phase scenario: pmsm (sstp), four-switch (fstp) with
# each drop compensation and the current model, dtifc sensorless and field weakening
DTC_SCENARIOS = ['two_phase_six_switch_torque_step', 'two_phase_six_switch_flux_control',
                 'two_phase_six_switch_nonideal_torque', 'two_phase_four_switch_torque_step',
                 'two_phase_four_switch_flux_control', 'sstp_voltage_model_no_compensation',
                 'sstp_voltage_model_simple_compensation', 'sstp_current_model_full_load',
                 'fstp_voltage_model_no_compensation', 'fstp_voltage_model_simple_compensation',
                 'fstp_voltage_model_proposed_compensation', 'fstp_current_model_full_load',
                 'three_phase_dtifc_sensorless', 'three_phase_dtifc_field_weakening']


def test_kernels_are_compiled():
    assert not jit_disabled()
    assert hasattr(two_phase_step, 'py_func') and hasattr(three_phase_step, 'py_func')


def test_compiled_equals_interpreted_bit_for_bit(tmp_path):
    interpreted, compiled = interpreted_and_compiled('drive_testing.compiled_parity:scenario_arrays',
                                                     [DTC_SCENARIOS, 0.02], tmp_path)
    torque = compiled['two_phase_four_switch_torque_step:dtc/status.torque_estimate']
    assert torque.size > 100 and np.ptp(torque) > 0.0          # a real, moving trajectory
    for name in ('fstp_voltage_model_proposed_compensation', 'three_phase_dtifc_field_weakening'):
        assert np.ptp(compiled[f'{name}:dtc/status.torque_estimate']) > 0.0
    assert differing(interpreted, compiled) == []


def test_three_phase_options_compiled_equal_interpreted(tmp_path):
    """Options no shipped scenario uses (sine rotor flux, LPF compensation, table flux reference,
    sensorless pmsm, encoder dtifc, a runtime change of rotation and drop compensation)."""
    interpreted, compiled = interpreted_and_compiled('dtc_test_tables:dtc_option_arrays',
                                                     [2000], tmp_path)
    for n in range(len(DTC_OPTION_CASES)):
        assert np.ptp(compiled[f'{n}:torque_estimate']) > 0.0 and np.ptp(compiled[f'{n}:sector']) > 0.0
    assert differing(interpreted, compiled) == []
