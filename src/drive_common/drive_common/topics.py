"""Topic, action and service names of the drive graph (relative: a namespace moves the whole
graph) and their QoS (docs/architecture.md "Time and lockstep")."""
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
PARAMETER_EVENTS = '/parameter_events'
RUN_ACTION = 'plant/run'
RESET_PROTECTION_SERVICE = 'plant/reset_protection'
RECORDER_MATCHED_SERVICE = 'recorder/matched_publishers'   # dtc_msgs/srv/MatchedPublishers
DIAGNOSTICS = '/diagnostics'
CLOCK = '/clock'

LOCKSTEP_DEPTH = 2000
STREAM_DEPTH = 10000
BLOCK_DEPTH = 1000
LIVE_DEPTH = 100
FIRST_ANSWER_RESEND = 2.0   # s wall: re-send an unanswered first measurement (lost before matching)


def _reliable(depth: int | None) -> QoSProfile:
    """RELIABLE, VOLATILE; KEEP_LAST depth, or KEEP_ALL for depth None."""
    history = ({'history': HistoryPolicy.KEEP_ALL} if depth is None
               else {'history': HistoryPolicy.KEEP_LAST, 'depth': depth})
    return QoSProfile(**history, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)


LOCKSTEP_QOS = _reliable(LOCKSTEP_DEPTH)
"""The measurement/command handshake; the depth lets a recorder of these topics lag."""

LOCKSTEP_READER_QOS = _reliable(None)
"""The nodes' own lockstep readers: KEEP_ALL, so an intruder's burst cannot push the peer's
sample out (a KEEP_LAST depth is shared by every writer)."""

STREAM_QOS = _reliable(STREAM_DEPTH)
"""Per-sample topics nobody waits on, recorded at full rate (raw lockstep copies)."""

BLOCK_QOS = _reliable(BLOCK_DEPTH)
"""Full-rate telemetry blocks: a starved recorder catches up, the publisher never blocks."""

LIVE_QOS = _reliable(LIVE_DEPTH)
"""Decimated live topics: shallow, reliable (reliable and best-effort readers both match)."""
