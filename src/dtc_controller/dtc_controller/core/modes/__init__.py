"""DTC modes, one module each; :data:`MODE_CLASSES` maps the ``mode`` parameter to a class.

A mode class is built as ``cls(params: dict, backemf: BackEmfTable | None)``
and provides ``topology`` (4 or 6), ``apply_runtime(params)`` (references,
bands, gains at the next sample) and ``step(sample) -> (switch_on, DtcStatusSample)``.
Three-phase modes (three_phase_dtifc, three_phase_pmsm, three_phase_four_switch)
are reserved for modules added beside these.
"""
from __future__ import annotations

from .three_phase_dtifc import ThreePhaseDtifcMode
from .three_phase_four_switch import ThreePhaseFourSwitchMode
from .three_phase_pmsm import ThreePhasePmsmMode
from .two_phase_four_switch import TwoPhaseFourSwitchMode
from .two_phase_six_switch import TwoPhaseSixSwitchMode

MODE_CLASSES = {
    TwoPhaseSixSwitchMode.name: TwoPhaseSixSwitchMode,
    TwoPhaseFourSwitchMode.name: TwoPhaseFourSwitchMode,
    ThreePhaseDtifcMode.name: ThreePhaseDtifcMode,
    ThreePhasePmsmMode.name: ThreePhasePmsmMode,
    ThreePhaseFourSwitchMode.name: ThreePhaseFourSwitchMode,
}
RESERVED = ('three_phase_dtifc', 'three_phase_pmsm', 'three_phase_four_switch')


def mode_class(name: str):
    """The class of mode `name`; NotImplementedError for a reserved, not yet added mode."""
    if name in MODE_CLASSES:
        return MODE_CLASSES[name]
    if name in RESERVED:
        raise NotImplementedError(f'mode {name!r} is reserved but not implemented in this build')
    raise ValueError(f'unknown mode {name!r}; known: {", ".join(sorted(MODE_CLASSES) + list(RESERVED))}')
