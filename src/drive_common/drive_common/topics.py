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
FIRST_ANSWER_RESEND = 2.0   # s wall: re-send an unanswered first measurement (lost before matching;
                            # a controller answers a repeated measurement from its cache)


def _reliable(depth: int | None) -> QoSProfile:
    """RELIABLE, VOLATILE; KEEP_LAST depth, or KEEP_ALL for depth None."""
    history = ({'history': HistoryPolicy.KEEP_ALL} if depth is None
               else {'history': HistoryPolicy.KEEP_LAST, 'depth': depth})
    return QoSProfile(**history, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)


LOCKSTEP_QOS = _reliable(LOCKSTEP_DEPTH)
"""QoS of the measurement/command handshake: nothing lost, nothing stale replayed.

At most one message per controller is outstanding in the handshake; the
depth only lets a slower reader (the recorder, when a scenario records the
lockstep topics) lag without losing a sample: a reliable KEEP_LAST writer
drops its oldest unacknowledged sample when its history is full, and a
recorder starved of CPU for a few hundred samples lost the start of a run
with a depth of 64.
"""

LOCKSTEP_READER_QOS = _reliable(None)
"""QoS of the plant's and a controller's own lockstep readers (compatible with LOCKSTEP_QOS).

KEEP_LAST's depth is shared by every writer of a topic: a burst from another
publisher (a stray ``ros2 topic pub``) would push the peer's pending sample
out of the reader before it is taken. KEEP_ALL keeps it; the intruder's
messages are taken and dropped (drive_common.peer_binding).
"""

STREAM_QOS = _reliable(STREAM_DEPTH)
"""QoS of per-sample streamed topics nobody waits on, recorded at full rate (raw lockstep copies).

The writer keeps up to STREAM_DEPTH unacknowledged samples, so a reader
that falls behind for a while (the recorder during a disk flush) still
receives every sample; the plant never blocks on it.
"""

BLOCK_QOS = _reliable(BLOCK_DEPTH)
"""QoS of the full-rate telemetry blocks (plant/state_block, dtc/status_block, pfc/status_block).

RELIABLE, KEEP_LAST BLOCK_DEPTH: 1000 blocks are 2 s of sim time at the
default 80 samples of 25 us per block (about 20 s of wall time at the
graph's rate), so a recorder starved of CPU catches up without losing a
block; the publisher never blocks on it (KEEP_ALL would stall the lockstep
loop on a slow reader). The writer's history grows only as far as a reader
lags (about 23 kB per PlantStateBlock of 80 samples).
"""

LIVE_QOS = _reliable(LIVE_DEPTH)
"""QoS of the decimated per-sample live topics (plant/state, dtc/status, pfc/status).

Shallow: about 1 kHz of sim time for people and live tools; a reader that
falls behind by more than LIVE_DEPTH samples loses the oldest (the bag
keeps every sample through the blocks). Reliable, so reliable and
best-effort readers (``ros2 topic echo``, the recorder) both match.
"""
