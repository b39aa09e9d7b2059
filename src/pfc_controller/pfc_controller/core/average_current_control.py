"""Per-unit average current control of the boost PFC with input-voltage feed-forward (000 ch. III).

Per sample: per-unit rectified input A, its line-period average, C = 4 / (pi V_dc(pu) K_m)^2, the
voltage PI output B, I_ref(pu) = K_m A B C (eq. 3.1) and the current PI to the duty (TI ``pid_reg3``
PIs; ``current_loop_output_scale`` and ``duty_feedforward`` are our additions; docs/models.md
"Per-unit average current control"). Protection (000 3.3): over-current or over-voltage holds the
duty at 0, resets the current PI and freezes the voltage PI; ``enable`` false holds the duty at 0
and resets both loops; on enable the reference ramps from the measured v_o.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from drive_common.compiled import njit
from drive_common.samples import DutySample, PfcSample

from pfc_controller.core.feedforward import (LinePeriodAverage, average_update, feedforward_c,
                                             line_period_window)
from pfc_controller.core.pi import pi_update
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


# Parameter vector of the compiled step (float64; flags 0/1), filled by PfcCore.reconfigure.
(P_KM, P_INV_VMAX, P_INV_VBASE, P_IBASE, P_INV_IBASE, P_RAMP_STEP, P_VREF, P_OC_LIMIT, P_OV_LIMIT,
 P_ENABLE, P_DUTY_FF, P_SCALE, P_DUTY_MAX, P_VKP, P_VKI, P_VMAX_OUT, P_CKP, P_CKI, P_AVG_FRAC,
 P_SIZE) = range(20)
# Loop state (float64; flags 0/1): voltage PI, current PI, ramped reference (NaN: restart), B.
(S_VI, S_VU, S_VSAT, S_CI, S_CU, S_CSAT, S_REF, S_B, S_WAS_ENABLED, S_SIZE) = range(10)
# Outputs of one step, in PfcStatusSample's order from 'enabled' on, then the duty's enable.
(O_ENABLED, O_VREF, O_A, O_B, O_C, O_IREF, O_CLOOP, O_DUTY, O_VSAT, O_CSAT, O_OC, O_OV,
 O_SWITCH, O_SIZE) = range(14)


@njit
def _ramp_reference(prm, st, v_o: float) -> float:
    """Soft start: the reference moves from the measured v_o to V_o* at the ramp rate."""
    target = prm[P_VREF]
    step = prm[P_RAMP_STEP]
    ref = st[S_REF]
    if ref != ref:  # NaN: (re)start the soft start from the measured voltage
        ref = min(v_o, target) if step > 0.0 else target
    if step <= 0.0:
        ref = target
    elif ref < target:
        ref = min(ref + step, target)
    elif ref > target:
        ref = max(ref - step, target)
    st[S_REF] = ref
    return ref


@njit
def _disabled_or_tripped(prm, st, out, enabled: bool, v_ref: float) -> None:
    """Duty 0: loops reset on disable (eq. 3.1 not evaluated), current PI reset on a trip."""
    out[O_ENABLED] = 1.0 if enabled else 0.0
    out[O_SWITCH] = out[O_ENABLED]
    out[O_VREF] = v_ref
    out[O_CLOOP] = 0.0
    out[O_DUTY] = 0.0
    out[O_CSAT] = 0.0
    if enabled:
        st[S_CI] = 0.0
        st[S_CU] = 0.0
        st[S_CSAT] = 0.0
        out[O_B] = st[S_B]
        out[O_IREF] = prm[P_KM] * out[O_A] * st[S_B] * out[O_C] * prm[P_IBASE]
        out[O_VSAT] = st[S_VSAT]
        return
    if st[S_WAS_ENABLED] != 0.0:
        st[S_VI] = st[S_VU] = st[S_VSAT] = 0.0
        st[S_CI] = st[S_CU] = st[S_CSAT] = 0.0
        st[S_B] = 0.0
    st[S_WAS_ENABLED] = 0.0
    st[S_REF] = math.nan
    out[O_B] = 0.0
    out[O_IREF] = 0.0
    out[O_VSAT] = 0.0


@njit
def pfc_step(prm, st, buf, avg, n_avg: int, v_in: float, v_o: float, i_l: float, out) -> None:
    """One control sample (module doc: eqs. 3.1-3.6, the two PIs, protection) into out[O_*]."""
    a = max(v_in, 0.0) * prm[P_INV_VMAX]                                   # A, eq. (3.2) base V_max
    c = feedforward_c(average_update(buf, avg, n_avg, prm[P_AVG_FRAC], a), prm[P_KM])  # C (3.2)-(3.5)
    out[O_A] = a
    out[O_C] = c
    out[O_OC] = 1.0 if i_l > prm[P_OC_LIMIT] else 0.0
    out[O_OV] = 1.0 if v_o > prm[P_OV_LIMIT] else 0.0
    if prm[P_ENABLE] == 0.0:
        _disabled_or_tripped(prm, st, out, False, prm[P_VREF])
        return
    st[S_WAS_ENABLED] = 1.0
    v_ref = _ramp_reference(prm, st, v_o)
    if out[O_OC] != 0.0 or out[O_OV] != 0.0:
        _disabled_or_tripped(prm, st, out, True, v_ref)
        return
    b, st[S_VI], st[S_VU], vsat = pi_update(prm[P_VKP], prm[P_VKI], 0.0, prm[P_VMAX_OUT], st[S_VI],
                                            (v_ref - v_o) * prm[P_INV_VBASE])  # B, voltage PI G_v
    st[S_VSAT] = 1.0 if vsat else 0.0
    st[S_B] = b
    i_ref_pu = prm[P_KM] * a * b * c                                       # eq. (3.1)
    d_ff = (1.0 - v_in / v_o) if (prm[P_DUTY_FF] != 0.0 and v_o > v_in > 0.0) else 0.0
    scale = prm[P_SCALE]
    d_max = prm[P_DUTY_MAX]
    u, st[S_CI], st[S_CU], csat = pi_update(prm[P_CKP], prm[P_CKI], (0.0 - d_ff) / scale,
                                            (d_max - d_ff) / scale, st[S_CI],
                                            i_ref_pu - i_l * prm[P_INV_IBASE])  # current PI G_i
    st[S_CSAT] = 1.0 if csat else 0.0
    out[O_ENABLED] = out[O_SWITCH] = 1.0
    out[O_VREF] = v_ref
    out[O_B] = b
    out[O_IREF] = i_ref_pu * prm[P_IBASE]
    out[O_CLOOP] = d_ff + scale * st[S_CU]
    out[O_DUTY] = min(max(d_ff + scale * u, 0.0), d_max)
    out[O_VSAT] = st[S_VSAT]
    out[O_CSAT] = st[S_CSAT]
    out[O_OC] = out[O_OV] = 0.0


class PfcCore:
    """Average current control PFC (eqs. 3.1-3.6); ``update`` once per sample runs the compiled
    :func:`pfc_step` on float64 arrays held here."""

    def __init__(self, params: Mapping[str, Any] | None = None) -> None:
        self._p: dict[str, Any] = {}
        self._average: LinePeriodAverage | None = None
        self._prm = np.zeros(P_SIZE)
        self._st = np.zeros(S_SIZE)
        self._st[S_REF] = math.nan       # V, ramped reference; NaN = start from measurement
        self._out = np.zeros(O_SIZE)
        self.reconfigure(PFC_SCHEMA.resolve(dict(params or {})))

    @property
    def params(self) -> dict[str, Any]:
        return dict(self._p)

    @property
    def km(self) -> float:
        """Eq. (3.6): K_m = V_max / V_min."""
        return float(self._prm[P_KM])

    def check(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """The validated snapshot of a parameter change (this core untouched); ParameterError or
        ValueError to refuse it."""
        p = PFC_SCHEMA.validate_changes(self._p or PFC_SCHEMA.defaults(), dict(params))
        if self._line_period_changed(p):
            line_period_window(p['line_frequency'], p['sample_period'])   # validates, builds nothing
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
        prm = self._prm
        prm[P_KM] = p['input_voltage_max'] / p['input_voltage_min']
        prm[P_INV_VMAX] = 1.0 / p['input_voltage_max']
        prm[P_INV_VBASE] = 1.0 / p['output_voltage_base']
        prm[P_IBASE] = p['current_base']
        prm[P_INV_IBASE] = 1.0 / p['current_base']
        prm[P_RAMP_STEP] = p['voltage_reference_ramp_rate'] * p['sample_period']
        prm[P_VREF] = p['voltage_reference']
        prm[P_OC_LIMIT] = p['over_current_limit']
        prm[P_OV_LIMIT] = p['over_voltage_limit']
        prm[P_ENABLE] = 1.0 if p['enable'] else 0.0
        prm[P_DUTY_FF] = 1.0 if p['duty_feedforward'] else 0.0
        prm[P_SCALE] = p['current_loop_output_scale']
        prm[P_DUTY_MAX] = p['duty_max']
        prm[P_VKP], prm[P_VKI], prm[P_VMAX_OUT] = p['voltage_kp'], p['voltage_ki'], p['voltage_loop_output_max']
        prm[P_CKP], prm[P_CKI] = p['current_kp'], p['current_ki']
        prm[P_AVG_FRAC] = self._average.frac
        self._st[S_VI] = min(self._st[S_VI], prm[P_VMAX_OUT])

    def update(self, sample: PfcSample) -> tuple[DutySample, PfcStatusSample]:
        """One control sample: measurement at t_k -> duty for [t_k, t_k + T_s) and status."""
        avg = self._average
        pfc_step(self._prm, self._st, avg.buffer, avg.state, avg.n, float(sample.rectified_voltage),
                 float(sample.output_voltage), float(sample.inductor_current), self._out)
        return samples_of(sample.step, self._out.tolist())

    def fused_arrays(self) -> tuple:
        """(parameters, loop state, average ring, average state, window n, outputs): what a fused
        loop passes to :func:`pfc_step` for this core (updated in place)."""
        avg = self._average
        return self._prm, self._st, avg.buffer, avg.state, avg.n, self._out


def samples_of(step: int, out: list) -> tuple[DutySample, PfcStatusSample]:
    """The duty command and status of a sample from :func:`pfc_step`'s outputs (O_* order)."""
    (enabled, v_ref, a, b, c, i_ref, c_loop, duty, vsat, csat, oc, ov, switch) = out
    return (DutySample(step, duty, switch != 0.0),
            PfcStatusSample(step, enabled != 0.0, v_ref, a, b, c, i_ref, c_loop, duty,
                            vsat != 0.0, csat != 0.0, oc != 0.0, ov != 0.0))
