"""Per-unit average current control of the boost PFC with input-voltage feed-forward (000 ch. III).

One :meth:`PfcCore.update` per controller sample T_s (12.5 us = 80 kHz):

* A = v_in / V_max                          per-unit rectified input (eq. 3.2 base)
* V_dc(pu) = (1/T) int_T A dt               line-period average (3.2)
* C = 4 / (pi V_dc(pu) K_m)^2               = V_inv(pu)^2 (3.3)-(3.5), K_m = V_max/V_min (3.6)
* B = G_v(V_ref(pu) - V_o(pu))              voltage PI, V_o(pu) = v_o / V_o,base, B in [0, B_max]
* I_ref(pu) = K_m A B C                     (3.1); I_ref = I_ref(pu) * I_base  [A]
* d = G_i(I_ref(pu) - I_in(pu))             current PI -> duty (limits [0, d_max])

Interpretation of the per-unit system (the seed's OCR text only gives the
formulas; this is how they combine, checked by the averaged-model test):

1. For a sinusoidal line of peak V_p, A = (V_p/V_max)|sin wt| and
   V_dc(pu) = 2 V_p / (pi V_max), so K_m A C = (V_min / V_p)|sin wt| and
   I_ref = B I_base (V_min / V_p)|sin wt|. The average input power is
   P_in = B * V_min I_base / 2, independent of the line amplitude: B is the
   per-unit power demand with base P_base = V_min I_base / 2, and B = 1
   (the limit) is the rated power drawn at the minimum line, which is what
   K_m in (3.1)/(3.6) is for. The loop gain from B to V_o, and so the
   voltage-loop dynamics, does not change with the line voltage.
2. Bases: A on V_max (eq. 3.2), V_o on ``output_voltage_base`` (160 V:
   twice V_o*, above the 140 V trip, like a sensor full scale), I_in and
   I_ref on ``current_base`` (10 A, above the 8 A trip).
3. The PIs are the series form of TI's F281x ``pid_reg3`` (the seed's
   eZdsp F2812 platform): u = K_p e + x, x += K_i K_p e, K_i = T_s / T_i.
   At 80 kHz this puts the current-PI zero at K_ii / T_s = 2.5 krad/s
   (398 Hz) and the voltage-PI zero at 1.1 krad/s; read as a parallel PI
   (x += K_i e) the current loop would be integral-dominated (zero above
   Nyquist) and ring, which the averaged-model test rejects.
4. K_pi = 0.005 per unit is two orders too small to act on the duty
   directly (crossover K_pi V_o / (L I_base) = 40 rad/s at 10 A base); the
   seed's fixed-point scaling between the current-PI output and the PWM
   compare value is not printed. ``current_loop_output_scale`` (default
   125) is that scaling: d = d_ff + 125 u, which puts the current-loop
   crossover 125 K_pi V_o / (L I_base) = 5 krad/s at twice the PI zero
   (about 60 deg phase margin) for L = 1 mH, V_o = 80 V.
5. ``duty_feedforward`` adds d_ff = 1 - v_in / v_o (averaged boost model) so
   the PI supplies only the inductor-voltage correction (not in the seed; it
   can be switched off).
6. With a resistive load the voltage loop is integral action on the load
   pole 2/(R C): crossover about K_pv K_iv/T_s * V_min I_base/(2 C V_o V_o,base)
   / (2/(R C)), 10-16 Hz for 59-92 ohm, so the 120 Hz output ripple barely
   modulates B and the line current stays sinusoidal. A constant-power load
   removes that pole and would need a larger K_pv (not checked here).

Protection (seed 3.3): an inductor current above ``over_current_limit`` or an
output voltage above ``over_voltage_limit`` raises its flag; while a flag is
present the duty is held at 0 (the plant opens the switch itself), the
current PI is reset and the voltage PI is frozen. ``enable`` false holds the
duty at 0 with enable false and resets both loops; on enable the reference
ramps from the measured v_o to V_o* at ``voltage_reference_ramp_rate``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

from drive_common.samples import DutySample, PfcSample

from pfc_controller.core.feedforward import LinePeriodAverage, feedforward_c
from pfc_controller.core.pi import PiController
from pfc_controller.parameters import PFC_SCHEMA


@dataclass(slots=True)
class PfcStatusSample:
    """dtc_msgs/PfcStatus without the header (field names identical)."""

    step: int
    enabled: bool
    voltage_reference: float       # V, reference in use (ramped towards V_o*)
    input_per_unit: float          # 1, A
    voltage_loop_output: float     # 1, B
    feedforward: float             # 1, C
    current_reference: float       # A, I_ref(pu) * I_base
    current_loop_output: float     # 1, duty before the limits (d_ff + scale * u)
    duty: float                    # 1, in [0, 1]
    voltage_loop_saturated: bool
    current_loop_saturated: bool
    over_current: bool
    over_voltage: bool


class PfcCore:
    """Average current control PFC (eqs. 3.1-3.6); ``update`` once per sample."""

    def __init__(self, params: Mapping[str, Any] | None = None) -> None:
        self._p: dict[str, Any] = {}
        self._average: LinePeriodAverage | None = None
        self._voltage_pi = PiController(0.0, 0.0, 0.0, 1.0)
        self._current_pi = PiController(0.0, 0.0, -1.0, 1.0)
        self._reference = math.nan       # V, ramped reference; NaN = start from measurement
        self._b = 0.0
        self._was_enabled = False
        self.reconfigure(PFC_SCHEMA.resolve(dict(params or {})))

    @property
    def params(self) -> dict[str, Any]:
        return dict(self._p)

    @property
    def km(self) -> float:
        """Eq. (3.6): K_m = V_max / V_min."""
        return self._km

    def check(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """The validated snapshot of a parameter change; ParameterError / ValueError to refuse it.

        Nothing of the running core changes (the lockstep node validates every change with this).
        """
        p = PFC_SCHEMA.validate_changes(self._p or PFC_SCHEMA.defaults(), dict(params))
        if self._line_period_changed(p):
            LinePeriodAverage(p['line_frequency'], p['sample_period'])
        return p

    def _line_period_changed(self, p: Mapping[str, Any]) -> bool:
        return (self._average is None or p['line_frequency'] != self._p.get('line_frequency')
                or p['sample_period'] != self._p.get('sample_period'))

    def reconfigure(self, params: Mapping[str, Any]) -> None:
        """Take a new parameter snapshot (validated by :meth:`check`); it acts from the next update."""
        p = self.check(params)
        if self._line_period_changed(p):
            self._average = LinePeriodAverage(p['line_frequency'], p['sample_period'])
        self._p = p
        self._km = p['input_voltage_max'] / p['input_voltage_min']
        self._inv_vmax = 1.0 / p['input_voltage_max']
        self._inv_vbase = 1.0 / p['output_voltage_base']
        self._ibase = p['current_base']
        self._inv_ibase = 1.0 / p['current_base']
        self._ramp_step = p['voltage_reference_ramp_rate'] * p['sample_period']
        vpi, cpi = self._voltage_pi, self._current_pi
        vpi.kp, vpi.ki, vpi.out_min, vpi.out_max = (
            p['voltage_kp'], p['voltage_ki'], 0.0, p['voltage_loop_output_max'])
        vpi.integral = min(vpi.integral, vpi.out_max)
        cpi.kp, cpi.ki = p['current_kp'], p['current_ki']

    def reset(self) -> None:
        """Back to the power-up state (loops cleared, feed-forward history dropped)."""
        self._voltage_pi.reset()
        self._current_pi.reset()
        self._average.reset()
        self._reference = math.nan
        self._b = 0.0
        self._was_enabled = False

    def _ramp_reference(self, v_o: float) -> float:
        target = self._p['voltage_reference']
        ref = self._reference
        if ref != ref:  # NaN: (re)start the soft start from the measured voltage
            ref = min(v_o, target) if self._ramp_step > 0.0 else target
        if self._ramp_step <= 0.0:
            ref = target
        elif ref < target:
            ref = min(ref + self._ramp_step, target)
        elif ref > target:
            ref = max(ref - self._ramp_step, target)
        self._reference = ref
        return ref

    def update(self, sample: PfcSample) -> tuple[DutySample, PfcStatusSample]:
        """One control sample: measurement at t_k -> duty for [t_k, t_k + T_s) and status."""
        p = self._p
        v_in = sample.rectified_voltage
        v_o = sample.output_voltage
        i_l = sample.inductor_current
        a = max(v_in, 0.0) * self._inv_vmax                     # A, eq. (3.2) base V_max
        c = feedforward_c(self._average.update(a), self._km)     # C, eqs. (3.2)-(3.5)
        over_current = i_l > p['over_current_limit']
        over_voltage = v_o > p['over_voltage_limit']
        vpi, cpi = self._voltage_pi, self._current_pi

        if not p['enable']:
            if self._was_enabled:
                vpi.reset()
                cpi.reset()
                self._b = 0.0
            self._was_enabled = False
            self._reference = math.nan
            return (DutySample(sample.step, 0.0, False),
                    PfcStatusSample(sample.step, False, p['voltage_reference'], a, 0.0, c, 0.0,
                                    0.0, 0.0, False, False, over_current, over_voltage))
        self._was_enabled = True
        v_ref = self._ramp_reference(v_o)

        if over_current or over_voltage:
            cpi.reset()
            cpi.saturated = False
            i_ref = self._km * a * self._b * c * self._ibase
            return (DutySample(sample.step, 0.0, True),
                    PfcStatusSample(sample.step, True, v_ref, a, self._b, c, i_ref, 0.0, 0.0,
                                    vpi.saturated, False, over_current, over_voltage))

        b = vpi.update((v_ref - v_o) * self._inv_vbase)           # B, voltage PI G_v
        self._b = b
        i_ref_pu = self._km * a * b * c                           # eq. (3.1)
        d_ff = (1.0 - v_in / v_o) if (p['duty_feedforward'] and v_o > v_in > 0.0) else 0.0
        scale = p['current_loop_output_scale']
        d_max = p['duty_max']
        u = cpi.update(i_ref_pu - i_l * self._inv_ibase,          # current PI G_i
                       (0.0 - d_ff) / scale, (d_max - d_ff) / scale)
        duty = min(max(d_ff + scale * u, 0.0), d_max)
        return (DutySample(sample.step, duty, True),
                PfcStatusSample(sample.step, True, v_ref, a, b, c, i_ref_pu * self._ibase,
                                d_ff + scale * cpi.output_unlimited, duty,
                                vpi.saturated, cpi.saturated, False, False))
