"""Metric modules, one per family of seed results (two-phase, three-phase, ripple, PFC).

Every public function of these modules is a metric (:mod:`drive_analysis.registry`).
"""

RATED_TORQUE_000 = 1.28352      # N m, the 000 BLDC motor (000 Appendix A)
RATED_TORQUE_001 = 0.3          # N m, the 001 PM BLAC motor (001 Table VIII)
