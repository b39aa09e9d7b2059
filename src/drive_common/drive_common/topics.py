"""Topic, action and service names of the drive graph and the lockstep QoS (docs/architecture.md, "Time and lockstep").

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
PLANT_STATE_BLOCK = 'plant/state_block'
DTC_STATUS_BLOCK = 'dtc/status_block'
PFC_STATUS_BLOCK = 'pfc/status_block'
RUN_ACTION = 'plant/run'
RESET_PROTECTION_SERVICE = 'plant/reset_protection'
DIAGNOSTICS = '/diagnostics'
CLOCK = '/clock'

LOCKSTEP_DEPTH = 64
STREAM_DEPTH = 10000

LOCKSTEP_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=LOCKSTEP_DEPTH,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""QoS of the measurement/command handshake: nothing lost, nothing stale replayed.

At most one message per controller is outstanding in the handshake; the
depth only lets a slower reader (the recorder) lag a little without losing
a sample.
"""

STREAM_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=STREAM_DEPTH,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""QoS of the streamed topics nobody waits on (plant/state, dtc/status, pfc/status).

The writer keeps up to STREAM_DEPTH unacknowledged samples, so a reader
that falls behind for a while (the recorder during a disk flush) still
receives every sample; the plant never blocks on it.
"""
