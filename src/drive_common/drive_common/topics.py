"""Topic, action and service names of the drive graph and the lockstep QoS (DESIGN.md §3).

Lockstep topics are RELIABLE, VOLATILE, KEEP_LAST with a small depth; /clock
is never used as the handshake. Names are relative so a namespace or
remapping moves the whole graph.
"""
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

DRIVE_MEASUREMENT = 'drive/measurement'
GATE_COMMAND = 'drive/gate_command'
PFC_MEASUREMENT = 'pfc/measurement'
DUTY_COMMAND = 'pfc/duty_command'
PLANT_STATE = 'plant/state'
DTC_STATUS = 'dtc/status'
PFC_STATUS = 'pfc/status'
RUN_ACTION = 'plant/run'
RESET_PROTECTION_SERVICE = 'plant/reset_protection'
DIAGNOSTICS = '/diagnostics'
CLOCK = '/clock'

LOCKSTEP_DEPTH = 8

LOCKSTEP_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=LOCKSTEP_DEPTH,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""QoS of measurement/command/status/state topics: nothing lost, nothing stale replayed."""
