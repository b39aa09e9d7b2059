"""DtcCore: the ROS-agnostic DTC controller, dispatching by the ``mode`` parameter."""
from __future__ import annotations

from drive_common.samples import DriveSample, GateSample

from ..parameters import DTC_SCHEMA
from .backemf_table import BackEmfTable
from .modes import mode_class
from .status import DtcStatusSample

__all__ = ['DtcCore', 'DtcStatusSample']


class DtcCore:
    """One DTC controller on a (partial) ``DTC_SCHEMA`` snapshot and a back-EMF table (None: loaded
    from ``backemf_table_path`` when the mode needs one).

    ``update(sample)`` runs one sample; ``reconfigure(params)`` acts at the next sample boundary:
    runtime parameters in place (estimator state kept), any other change rebuilds the mode.
    """

    def __init__(self, params: dict, backemf: BackEmfTable | None = None) -> None:
        self.params = DTC_SCHEMA.validate_changes(DTC_SCHEMA.defaults(), dict(params))
        self.backemf = backemf   # the table in use (None without one)
        self._pending: dict | None = None
        self._checked: tuple[tuple, BackEmfTable] | None = None   # the table check last loaded
        self._build()

    def _table_for(self, p: dict) -> BackEmfTable | None:
        """The back-EMF table snapshot p needs: the loaded one unless its file or motor changed."""
        if self.backemf is not None and not self._table_changed(p):
            return self.backemf
        if not p['backemf_table_path']:
            return None
        key = (p['backemf_table_path'], p['motor.pole_pairs'])
        if self._checked is None or self._checked[0] != key:
            # Kept: the reconfigure that follows a check builds with this table, not a re-read.
            self._checked = (key, BackEmfTable.load(*key))
        return self._checked[1]

    def _table_changed(self, p: dict) -> bool:
        return any(p[n] != self.params[n] for n in ('backemf_table_path', 'motor.pole_pairs'))

    def _build(self) -> None:
        p = self.params
        self.backemf = self._table_for(p)
        self.mode = mode_class(p['mode']).create(p, self.backemf)
        self.topology = self.mode.topology

    def check(self, params: dict) -> dict:
        """The validated snapshot of a parameter change, this core untouched: ParameterError (a value),
        BackEmfTableError (a new table file) or ValueError (the mode cannot run with it)."""
        p = DTC_SCHEMA.validate_changes(self.params, dict(params))
        mode_class(p['mode']).check(p, self._table_for(p))
        return p

    def reconfigure(self, params: dict) -> None:
        """Validate changes now (ParameterError on a bad value); apply them at the next sample."""
        base = self._pending if self._pending is not None else self.params
        self._pending = DTC_SCHEMA.validate_changes(base, dict(params))

    def _apply_pending(self) -> None:
        new, self._pending = self._pending, None
        structural = [n for n in DTC_SCHEMA.names() if not DTC_SCHEMA[n].runtime and new[n] != self.params[n]]
        if self._table_changed(new):
            self.backemf = None
        self.params = new
        if structural:
            self._build()
        else:
            self.mode.configure(new)

    def update(self, sample: DriveSample) -> tuple[GateSample, DtcStatusSample]:
        """One controller sample: measurement k -> gate command and status for step k."""
        if self._pending is not None:
            self._apply_pending()
        switch_on, status = self.mode.step(sample)
        return GateSample(sample.step, self.topology, switch_on), status
