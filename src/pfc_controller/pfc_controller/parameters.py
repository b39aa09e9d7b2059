"""Parameter schema of the pfc_controller node (pure: no rclpy).

Defaults reproduce the dissertation's boost PFC (000 ch. III, 3.3): V_o* = 80 V, 28.28-70.71 V peak
input (K_m = 2.5), K_pv = 0.1736, K_iv = 0.01388, K_pi = 0.005, K_ii = 0.03125 at 80 kHz, trips
8 A / 140 V. ``duty_feedforward`` and ``current_loop_output_scale`` are OUR ADDITIONS the shipped
PF/THD depend on (docs/models.md "Defaults and our additions"). Sample period, line frequency and
per-unit bases are ``runtime=False``.
"""
from __future__ import annotations

from typing import Any, Mapping

from drive_common.parameters import ParameterError, ParameterSpec, schema
from drive_common.telemetry import TELEMETRY_PARAMETERS


def _check_consistency(p: Mapping[str, Any]) -> None:
    """Cross-parameter rules; each failure names the rule."""
    v_ref, v_min, v_max = p['voltage_reference'], p['input_voltage_min'], p['input_voltage_max']
    rules = (
        (v_min < v_max, f"input_voltage_min ({v_min} V) must be below input_voltage_max ({v_max} V)"),
        (v_ref > v_max, f"voltage_reference ({v_ref} V) must exceed input_voltage_max ({v_max} V): "
                        "a boost converter cannot regulate below the input peak"),
        (v_ref < p['over_voltage_limit'], f"voltage_reference ({v_ref} V) must stay below "
                                          f"over_voltage_limit ({p['over_voltage_limit']} V)"),
        (v_ref <= p['output_voltage_base'],
         f"voltage_reference ({v_ref} V) must not exceed output_voltage_base ({p['output_voltage_base']} V): "
         "V_ref(pu) <= 1"),
        (p['line_frequency'] * p['sample_period'] <= 0.01,
         'sample_period must be at most 1/100 of the line period '
         '(the line-period average needs >= 100 samples per cycle)'),
    )
    for holds, message in rules:
        if not holds:
            raise ParameterError(message)


PFC_SCHEMA = schema([
    ParameterSpec('enable', True,
                  'PFC control active; false holds the boost switch off (plain diode rectifier)'),
    ParameterSpec('voltage_reference', 80.0, 'output DC voltage reference V_o*', 'V', 1.0, 1000.0),
    ParameterSpec('voltage_reference_ramp_rate', 400.0,
                  'slew rate of the internal reference from the measured V_o to V_o* after enable '
                  'or a reference change (soft start); 0 = step', 'V/s', 0.0, 1.0e6),
    ParameterSpec('voltage_kp', 0.1736,
                  'voltage PI proportional gain K_pv: per-unit B per per-unit V_o error', '', 0.0, 1000.0),
    ParameterSpec('voltage_ki', 0.01388, 'voltage PI integral gain K_iv (series form, = T_s/T_i per sample)',
                  '', 0.0, 1.0),
    ParameterSpec('current_kp', 0.005,
                  'current PI proportional gain K_pi: per-unit output per per-unit current error', '',
                  0.0, 1000.0),
    ParameterSpec('current_ki', 0.03125, 'current PI integral gain K_ii (series form, = T_s/T_i per sample)',
                  '', 0.0, 1.0),
    ParameterSpec('current_loop_output_scale', 125.0,
                  'OUR ADDITION (not in 000): duty per unit of current-PI output (the fixed-point PWM '
                  'scaling the seed does not print; 1 = the seed as printed; 125 puts the current-loop crossover at twice the PI zero)', '',
                  1.0e-3, 1.0e4),
    ParameterSpec('duty_feedforward', True,
                  'OUR ADDITION (not in 000): add the averaged-model boost duty 1 - v_in/v_o to the '
                  'current-PI output', ''),
    ParameterSpec('voltage_loop_output_max', 1.0,
                  'upper limit of B (per-unit input power demand, base V_min*I_base/2)', '', 0.01, 10.0),
    ParameterSpec('duty_max', 0.95, 'upper duty limit', '', 0.0, 1.0),
    ParameterSpec('input_voltage_max', 70.71,
                  'V_max: maximum peak rectified input voltage, per-unit base of A (eq. 3.2)', 'V',
                  1.0, 1000.0, runtime=False),
    ParameterSpec('input_voltage_min', 28.28,
                  'V_min: minimum peak rectified input voltage (K_m = V_max/V_min, eq. 3.6)', 'V',
                  0.1, 1000.0, runtime=False),
    ParameterSpec('output_voltage_base', 160.0,
                  'per-unit base of the output voltage (sensor full scale, above the OV trip)', 'V',
                  1.0, 2000.0, runtime=False),
    ParameterSpec('current_base', 10.0,
                  'per-unit base of the inductor current I_ref, I_in (sensor full scale, above the '
                  'OC trip)', 'A', 0.01, 1000.0, runtime=False),
    ParameterSpec('over_current_limit', 8.0,
                  'inductor over-current protection threshold (flag, duty held at 0)', 'A', 0.0, 1000.0),
    ParameterSpec('over_voltage_limit', 140.0,
                  'output over-voltage protection threshold (flag, duty held at 0)', 'V', 0.0, 2000.0),
    ParameterSpec('line_frequency', 60.0,
                  'grid frequency; the feed-forward averages A over one line period (eq. 3.2)', 'Hz',
                  1.0, 1000.0, runtime=False),
    ParameterSpec('sample_period', 12.5e-6,
                  'controller sample period T_s (12.5 us = 80 kHz); a multiple of the plant tick',
                  's', 1.0e-7, 1.0e-2, runtime=False),
    *TELEMETRY_PARAMETERS,
], _check_consistency)
