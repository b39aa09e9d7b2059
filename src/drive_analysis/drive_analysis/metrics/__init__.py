"""Metric modules, one per family of seed results (two-phase, three-phase, ripple, PFC).

Every public function of these modules is a metric (:mod:`drive_analysis.registry`), named by
the ``metric:`` keys of the scenarios' checks: it takes the flat arrays dict of a run
(:mod:`drive_analysis.arrays`; plant ground truth ``'plant/state.<field>'``, controller internals
``'dtc/status.<field>'`` / ``'pfc/status.<field>'``, rows paired by ``step``) plus keyword
options, and returns a float (NaN when the window holds no data). ``t_start`` / ``t_end`` [s]
restrict it to a window; angles are electrical. Definitions: docs/reference/metrics.md.
"""

RATED_TORQUE_000 = 1.28352      # N m, the 000 BLDC motor (000 Appendix A)
RATED_TORQUE_001 = 0.3          # N m, the 001 PM BLAC motor (001 Table VIII)
