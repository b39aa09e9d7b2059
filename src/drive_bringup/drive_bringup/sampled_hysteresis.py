"""First-order mean-torque deficit of sampled hysteresis DTC (derivation: docs/studies.md).

Two-phase conduction of the 000 BLDC (two phases in series, both on their
back-EMF flat tops, phase current i): the pair obeys
``v = 2 R i + 2 L_s di/dt + 2 E`` with ``L_s = L - M`` and ``E = K p w_m``,
and ``T = k_t i`` with ``k_t = 2 p K`` (000 eq. 2.16 on the flat tops). The
six-switch table (000 Table II) raises the torque with the active vector
(+V_dc across the pair) and lowers it with the reverse vector (-V_dc):

    s_up   = k_t (V_dc - 2 E - 2 R i) / (2 L_s)      [N m/s]
    s_down = k_t (V_dc + 2 E + 2 R i) / (2 L_s)

With a band far below one sample's torque step, the sampled comparator
turns every sample into a rotation on the interval
[T* - s_down T_s, T* + s_up T_s): the samples spread uniformly over it and
the mean torque is T* + (s_up - s_down) T_s / 2, a deficit

    dT = (s_down - s_up) T_s / 2 = k_t (E + R i) T_s / L_s,

linear in T_s and in the speed (through E), independent of V_dc.
"""
from __future__ import annotations


def predicted_torque_deficit_N_m(sample_period: float, speed: float, torque_reference: float,
                                 backemf_constant: float = 0.0573, pole_pairs: int = 2,
                                 resistance: float = 0.315, self_inductance: float = 1.4e-3,
                                 mutual_inductance: float = 0.3125e-3) -> float:
    """T* - mean torque [N m] at sample period T_s [s] and mechanical speed w_m [rad/s].

    Defaults: the 000 Appendix A motor (motors/ozturk_bldc.yaml): K [V s/rad per
    electrical rad/s], p, R [ohm], L, M [H]. The current i is taken at T*.
    """
    k_t = 2.0 * pole_pairs * backemf_constant                      # N m/A
    emf = backemf_constant * pole_pairs * speed                    # V, phase flat top
    current = torque_reference / k_t                               # A
    return k_t * (emf + resistance * current) * sample_period / (self_inductance - mutual_inductance)
