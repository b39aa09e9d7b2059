"""DC link: ideal source, or split capacitors C_upper + C_lower (000 ch. III/IV: C3 = C4 = 270 uF).

Nodes P (positive rail), M (midpoint), N (0 V); the inverter draws i_P from P and
i_M from M. Modes ``ideal``, ``split_capacitors`` (the midpoint drifts) and
``current_fed`` (the boost front end feeds ``source_current`` into P). Updates take
the charge each node drew over a segment; within a segment the inverter sees the
voltages predicted at the segment's middle (:meth:`DcLink.segment_voltages`), which
leaves a second-order residual. Equations and why: docs/models.md "DC link".
"""
from __future__ import annotations

import numpy as np

from .link_kernel import (DC_CL, DC_CU, DC_ES, DC_SIZE, DC_SRC, DC_V, DC_VL, DC_VU, link_draw,
                          link_stored_energy, link_voltages)

MODES = ('ideal', 'split_capacitors', 'current_fed')


def array_slot(index: int, doc: str, array: str = 'x', kind: type = float) -> property:
    """A float, int or bool attribute stored as a float in self.<array>[index] (a kernel's array)."""
    def get(self):
        value = getattr(self, array)[index]
        return value != 0.0 if kind is bool else kind(value)

    def set_(self, value):
        getattr(self, array)[index] = float(value)
    return property(get, set_, doc=doc)


class DcLink:
    """State in ``x`` (float64, slots of :mod:`.link_kernel`), advanced by its compiled kernels."""

    v_upper = array_slot(DC_VU, 'v_u = V_P - V_M [V]')
    v_lower = array_slot(DC_VL, 'v_l = V_M [V]')
    energy_source = array_slot(DC_ES, 'J delivered by the source')
    source_current = array_slot(DC_SRC, 'current_fed: source current into P [A]')
    voltage = array_slot(DC_V, 'V_dc [V]')
    c_upper = array_slot(DC_CU, 'F')
    c_lower = array_slot(DC_CL, 'F')

    def __init__(self, mode: str, voltage: float, c_upper: float, c_lower: float,
                 initial_midpoint: float = 0.5, source_current: float = 0.0) -> None:
        if mode not in MODES:
            raise ValueError(f'dc_link.mode {mode!r} is not one of {MODES}')
        self.x = np.zeros(DC_SIZE)
        self.mode = mode
        self.mode_code = MODES.index(mode)
        self.voltage = float(voltage)
        self.c_upper, self.c_lower = float(c_upper), float(c_lower)
        self.v_lower = self.voltage * initial_midpoint
        self.v_upper = self.voltage - self.v_lower
        if mode == 'ideal':
            self.v_lower = self.v_upper = 0.5 * self.voltage
        self.source_current = float(source_current)

    @classmethod
    def from_params(cls, p: dict) -> 'DcLink':
        return cls(p['dc_link.mode'], p['dc_link.voltage'], p['dc_link.upper_capacitance'],
                   p['dc_link.lower_capacitance'], p['dc_link.initial_midpoint'],
                   p['dc_link.source_current'])

    @property
    def positive(self) -> float:
        """V_P [V]."""
        return self.v_upper + self.v_lower

    def stored_energy(self) -> float:
        """Capacitor energy [J] (0 for the ideal source)."""
        return link_stored_energy(self.x, self.mode_code)

    def segment_voltages(self, dt: float) -> tuple[float, float]:
        """(V_P, V_M) [V] predicted at the middle of the next segment of length dt [s]."""
        return link_voltages(self.x, self.mode_code, dt)

    def draw(self, q_p: float, q_m: float, dt: float, time: float = 0.0) -> None:
        """The inverter drew charge q_p [C] from P and q_m from M over dt [s] (time: unused)."""
        link_draw(self.x, self.mode_code, q_p, q_m, dt)
