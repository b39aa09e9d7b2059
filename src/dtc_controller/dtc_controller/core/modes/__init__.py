"""DTC modes; :func:`mode_class` maps the ``mode`` parameter to a class.

A mode is built by ``cls.create(params, backemf)`` (:class:`regulation.DtcMode`) and provides
``topology`` (4 or 6), ``configure(params)`` (runtime parameters, from the next sample) and
``step(sample) -> (switch_on, DtcStatusSample)``.
"""
from __future__ import annotations

from .regulation import DtcMode
from .three_phase_dtifc import ThreePhaseDtifcMode
from .three_phase_pmsm import ThreePhaseFourSwitchMode, ThreePhasePmsmMode
from .two_phase_base import TwoPhaseSixSwitchMode
from .two_phase_four_switch import TwoPhaseFourSwitchMode

__all__ = ['DtcMode', 'MODE_CLASSES', 'mode_class']

MODE_CLASSES = {cls.name: cls for cls in (TwoPhaseSixSwitchMode, TwoPhaseFourSwitchMode, ThreePhaseDtifcMode,
                                          ThreePhasePmsmMode, ThreePhaseFourSwitchMode)}


def mode_class(name: str) -> type[DtcMode]:
    """The class of mode `name` (ValueError naming the known modes otherwise)."""
    try:
        return MODE_CLASSES[name]
    except KeyError:
        raise ValueError(f'unknown mode {name!r}; known: {", ".join(sorted(MODE_CLASSES))}') from None
