"""First-order mean-torque deficit of sampled hysteresis DTC (derivation: docs/studies.md).

Two-phase conduction of the 000 BLDC (two phases in series on their back-EMF
flat tops, phase current i, L_s = L - M, E = K p w_m, k_t = 2 p K): the active
vector raises the torque at s_up = k_t (V_dc - 2 E - 2 R i) / (2 L_s) and the
reverse vector lowers it at s_down = k_t (V_dc + 2 E + 2 R i) / (2 L_s) [N m/s].
With a band far below one sample's torque step the samples spread uniformly over
[T* - s_down T_s, T* + s_up T_s), so the mean torque falls short of T* by

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
