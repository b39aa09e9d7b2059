"""DtcCore: the ROS-agnostic DTC controller, dispatching by the ``mode`` parameter.

``DtcCore(params, backemf)`` takes a (partial) parameter snapshot of
:data:`dtc_controller.parameters.SCHEMA` (missing names take their
defaults) and the back-EMF table (or None: then it is loaded from
``backemf_table_path`` when the mode needs one). ``update(sample)`` runs one
controller sample; ``reconfigure(params)`` stores a new snapshot that takes
effect at the next sample boundary (runtime parameters are applied in place,
keeping estimator state; a change of a non-runtime parameter rebuilds the
mode, as when the simulation is held).
"""
from __future__ import annotations

from drive_common.samples import DriveSample, GateSample

from ..parameters import SCHEMA
from .backemf_table import BackEmfTable
from .modes import mode_class
from .status import DtcStatusSample

__all__ = ['DtcCore', 'DtcStatusSample']


class DtcCore:
    """One DTC controller; see the module doc."""

    def __init__(self, params: dict, backemf: BackEmfTable | None = None) -> None:
        self.params = SCHEMA.validate_changes(SCHEMA.defaults(), dict(params))
        self._backemf = backemf
        self._pending: dict | None = None
        self._build()

    def _build(self) -> None:
        p = self.params
        cls = mode_class(p['mode'])
        if self._backemf is None and p['backemf_table_path']:
            self._backemf = BackEmfTable.load(p['backemf_table_path'], p['motor.pole_pairs'])
        self.mode = cls(p, self._backemf)
        self.topology = self.mode.topology

    @property
    def backemf(self) -> BackEmfTable | None:
        return self._backemf

    def reconfigure(self, params: dict) -> None:
        """Validate changes now (ParameterError on a bad value); apply them at the next sample."""
        base = self._pending if self._pending is not None else self.params
        self._pending = SCHEMA.validate_changes(base, dict(params))

    def _apply_pending(self) -> None:
        new, self._pending = self._pending, None
        structural = [n for n in SCHEMA.names() if not SCHEMA[n].runtime and new[n] != self.params[n]]
        if 'backemf_table_path' in structural or 'motor.pole_pairs' in structural:
            self._backemf = None
        self.params = new
        if structural:
            self._build()
        else:
            self.mode.apply_runtime(new)

    def update(self, sample: DriveSample) -> tuple[GateSample, DtcStatusSample]:
        """One controller sample: measurement k -> gate command and status for step k."""
        if self._pending is not None:
            self._apply_pending()
        switch_on, status = self.mode.step(sample)
        return GateSample(sample.step, self.topology, switch_on), status
