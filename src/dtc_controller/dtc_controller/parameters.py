"""Parameter schema of the dtc_controller node (drive_common.parameters, no rclpy).

References, bands, gains, rotation and the flux-control switch change while running
(``runtime=True``, from the next sample, estimator state kept); a change of any other parameter
re-initialises the mode at the next sample boundary. ``mode`` also fixes the gate topology (4 or
6 switches): change the plant's ``inverter.topology`` with it while the simulation is held.
"""
from __future__ import annotations

from drive_common.parameters import ParameterError, ParameterSpec, schema
from drive_common.telemetry import TELEMETRY_PARAMETERS

MODES = ('two_phase_six_switch', 'two_phase_four_switch', 'three_phase_dtifc', 'three_phase_pmsm',
         'three_phase_four_switch')
"""The ``mode`` choices: one class each in :mod:`dtc_controller.core.modes`."""

# Appendix A motor of 000: R = 0.315 ohm, L = 1.4 mH, M = 0.3125 mH, P = 4 poles.
_SPECS = (
    ParameterSpec('mode', 'two_phase_six_switch', 'DTC mode (docs/architecture.md "DTC modes")', choices=MODES, runtime=False),
    ParameterSpec('sample_period', 25e-6, 'controller sample period T_s', 's', 1e-6, 1e-2, runtime=False),
    ParameterSpec('rotation', 1, 'commanded rotation: +1 counter-clockwise, -1 clockwise', choices=(1, -1)),
    ParameterSpec('torque_reference', 0.0, 'electromagnetic torque reference T* (signed; used without the speed loop)',
                  'N*m', -50.0, 50.0),
    ParameterSpec('torque_band', 0.001, 'torque hysteresis half-width H_T (eqs. 1.19-1.20)', 'N*m', 0.0, 10.0),
    ParameterSpec('four_switch.split_band_divisor', 1000.0,
                  'four-switch sectors II/V: phase-torque bands = torque_band / this (000 ch. IV)', '', 1.0, 1e6),
    ParameterSpec('speed_loop.enabled', False, 'outer speed PI loop produces T*'),
    ParameterSpec('speed_reference', 0.0, 'mechanical speed reference (signed)', 'rad/s', -2000.0, 2000.0),
    ParameterSpec('speed_loop.kp', 0.05, 'speed PI proportional gain', 'N*m*s/rad', 0.0, 1e3),
    ParameterSpec('speed_loop.ki', 1.0, 'speed PI integral gain', 'N*m/rad', 0.0, 1e6),
    ParameterSpec('speed_loop.period_samples', 10, 'speed PI runs every N controller samples', '', 1, 100000),
    ParameterSpec('speed_loop.torque_limit', 2.5, 'speed PI output (torque reference) limit', 'N*m', 0.0, 50.0),
    ParameterSpec('flux_control.enabled', False,
                  'flux hysteresis selects the phi = +-1 rows (000 Fig. 2.3 "switch state 1"; comparison only)'),
    ParameterSpec('flux_control.reference_source', 'backemf_table',
                  'flux reference: |psi_r(theta_e)| from the table (eq. 2.20) or the constant flux_reference',
                  choices=('backemf_table', 'constant')),
    ParameterSpec('flux_reference', 0.1146, 'constant stator flux reference |psi_s|*', 'Wb', 0.0, 10.0),
    ParameterSpec('flux_band', 0.001, 'flux hysteresis half-width H_lambda (eqs. 1.17-1.18)', 'Wb', 0.0, 1.0),
    ParameterSpec('backemf_table_path', '', 'back-EMF table CSV written by the plant generator test',
                  runtime=False),
    ParameterSpec('motor.resistance', 0.315, 'phase resistance R_s', 'ohm', 0.0, 100.0, runtime=False),
    ParameterSpec('motor.inductance', 1.0875e-3, 'phase inductance L - M', 'H', 1e-7, 1.0, runtime=False),
    ParameterSpec('motor.pole_pairs', 2, 'pole pairs p (theta_e = p theta_m)', '', 1, 100, runtime=False),
    ParameterSpec('estimation.voltage_model', 'diode_clamped',
                  'applied voltage for the flux model: ideal switch-state vectors or with free-wheeling '
                  'diode clamping of off legs that still carry current', choices=('ideal', 'diode_clamped'),
                  runtime=False),
    ParameterSpec('estimation.open_phase_emf', True,
                  'add the open phase back-EMF omega_e k_x(theta_e) to the applied voltage (curved flux locus)',
                  runtime=False),
    ParameterSpec('estimation.open_phase_current_threshold', 0.05,
                  'an off leg with |i| above this conducts through its diode', 'A', 0.0, 100.0, runtime=False),
    ParameterSpec('estimation.sector_source', 'rotor',
                  'sector from the encoder rotor angle or from the estimated stator flux angle',
                  choices=('rotor', 'flux'), runtime=False),
    ParameterSpec('estimation.encoder_offset', 0.0, 'added to the measured electrical encoder angle', 'rad',
                  -6.3, 6.3, runtime=False),
    ParameterSpec('estimation.initial_flux', 'backemf_table',
                  'initial stator flux: rotor flux at the first encoder angle from the table, or zero',
                  choices=('backemf_table', 'zero'), runtime=False),
    # ---- three-phase conduction modes (three_phase_dtifc / _pmsm / _four_switch)
    ParameterSpec('three_phase.flux_model', 'voltage',
                  'stator flux: voltage model (integrator below) or current model (001 eqs. 8-9, encoder angle)',
                  choices=('voltage', 'current'), runtime=False),
    ParameterSpec('three_phase.integrator', 'auto',
                  'voltage-model integrator; auto = the seed\'s: dtifc hu_wu, four_switch low_pass, pmsm pure',
                  choices=('auto', 'pure', 'low_pass', 'hu_wu'), runtime=False),
    ParameterSpec('three_phase.integrator_cutoff', 0.0,
                  'integrator cut-off w_c; 0 = seed value (hu_wu 20, low_pass 5)', 'rad/s', 0.0, 1e4,
                  runtime=False),
    ParameterSpec('three_phase.flux_limit', 0.0,
                  'Hu-Wu amplitude limit; 0 = rotor-flux amplitude (max |psi_r| of the table, else pm_flux)',
                  'Wb', 0.0, 10.0, runtime=False),
    ParameterSpec('three_phase.pm_flux', 0.0,
                  'PM flux-linkage amplitude psi_m used when no back-EMF table is loaded (001: 0.0928)',
                  'Wb', 0.0, 10.0, runtime=False),
    ParameterSpec('three_phase.low_pass_compensation', False,
                  'undo the low-pass integrator gain/phase error at the estimated speed'),
    ParameterSpec('three_phase.position_source', 'auto',
                  'rotor angle: sensorless eq. (5.38) or encoder; auto = dtifc sensorless, others encoder',
                  choices=('auto', 'sensorless', 'encoder'), runtime=False),
    ParameterSpec('three_phase.initial_angle', 0.0,
                  'sensorless start: rotor locked at this electrical angle (000 ch. V: 0 = phase a)', 'rad',
                  -6.3, 6.3, runtime=False),
    ParameterSpec('three_phase.speed_filter_cutoff', 200.0,
                  'low-pass cut-off of the sensorless speed estimate (derivative of the angle)', 'rad/s',
                  0.1, 1e5, runtime=False),
    ParameterSpec('dtifc.d_current_reference', 0.0,
                  'd-axis current reference i_d* (0 constant torque, < 0 field weakening)', 'A', -100.0, 100.0),
    ParameterSpec('dtifc.d_current_band', 0.001, 'd-current hysteresis half-width', 'A', 0.0, 100.0),
    ParameterSpec('voltage_drop.compensation', 'none',
                  'inverter voltage-drop compensation of the voltage model (001): none, simple (Table V), '
                  'proposed (Table VI + R_on terms)', choices=('none', 'simple', 'proposed')),
    ParameterSpec('voltage_drop.v_ce', 0.9, 'switch forward drop V_CE (001 Table IV)', 'V', 0.0, 20.0),
    ParameterSpec('voltage_drop.v_d', 1.25, 'diode forward drop V_d (001 Table IV)', 'V', 0.0, 20.0),
    ParameterSpec('voltage_drop.v_f', 0.9, 'forward drop of the simple scheme V_f (001 Table V)', 'V', 0.0, 20.0),
    ParameterSpec('voltage_drop.r_on', 0.075, 'on-state resistance R_on (001 Table IV)', 'ohm', 0.0, 10.0),
)


def _check_flux_reference(snapshot) -> None:
    if (snapshot['flux_control.enabled'] and snapshot['flux_control.reference_source'] == 'constant'
            and snapshot['flux_reference'] <= 0.0):
        raise ParameterError('flux_reference: must be > 0 Wb when flux control uses a constant reference')


DTC_SCHEMA = schema(_SPECS + TELEMETRY_PARAMETERS, _check_flux_reference)
"""The dtc_controller node's ParameterSchema."""
