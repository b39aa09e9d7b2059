"""Action goals whose reply is lost right after discovery: recovered, never run twice.

Fast DDS may drop a goal or result reply before the server's reply writers matched the
client. :func:`send_goal` re-sends under one goal id and takes acceptance from the action's
status topic; :func:`goal_result` asks again once the goal has ended. ``wait(done, seconds)``
is how a helper waits (:func:`polling_wait` when an executor spins the node elsewhere).
"""
from __future__ import annotations

import os
import threading
import time
import weakref
from typing import Any, Callable

from drive_common.waiting import wait_until

Wait = Callable[[Callable[[], bool], float], Any]

GOAL_RESPONSE_WAIT = 5.0   # s without a reply after which the status is asked and the goal sent again
GOAL_ATTEMPTS = 6
STATUS_WAIT = 2.0          # s the status topic may take to list a goal the server accepted
RESULT_ASK_AGAIN = 2.0     # s after which an ended goal's result is asked for again
RESULT_ASK_ANYWAY = 10.0   # s after which a result is asked for again, ended or not (a status missed)


def polling_wait(done: Callable[[], bool], seconds: float) -> bool:
    """Poll done() for up to seconds (the node is spun by an executor of its own)."""
    return bool(wait_until(done, seconds, 0.005, raise_timeout=False))


def within(wait: Wait, timeout: float) -> Wait:
    """wait, never past timeout s from now (may be inf), and True once that time has passed."""
    ends = time.monotonic() + timeout

    def bounded(done: Callable[[], bool], seconds: float):
        return wait(done, max(0.0, min(seconds, ends - time.monotonic()))) or time.monotonic() > ends
    return bounded


def _ended(status: int) -> bool:
    from action_msgs.msg import GoalStatus
    return status in (GoalStatus.STATUS_SUCCEEDED, GoalStatus.STATUS_ABORTED, GoalStatus.STATUS_CANCELED)


class GoalStatusWatch:
    """Every goal the action server has listed on its status topic: id -> (status, accept stamp)."""

    def __init__(self, node, action_name: str) -> None:
        from action_msgs.msg import GoalStatusArray
        from rclpy.qos import qos_profile_action_status_default
        self._goals: dict[bytes, tuple[int, Any]] = {}
        self._lock = threading.Lock()
        self.subscription = node.create_subscription(
            GoalStatusArray, f'{action_name}/_action/status', self._on_status, qos_profile_action_status_default)

    @classmethod
    def of(cls, client) -> 'GoalStatusWatch':
        """The watch of an rclpy ActionClient's action on its own node (one per client)."""
        watch = getattr(client, '_drive_status_watch', None)
        if watch is None:
            watch = client._drive_status_watch = cls(client._node, client._action_name)
        return watch

    def _on_status(self, msg) -> None:
        with self._lock:
            for entry in msg.status_list:
                self._goals[bytes(entry.goal_info.goal_id.uuid)] = (entry.status, entry.goal_info.stamp)

    def get(self, goal_id: bytes) -> tuple[int, Any] | None:
        with self._lock:
            return self._goals.get(goal_id)


def _adopted(client, goal_id, status: int, stamp):
    """The handle of a goal the server accepted but whose reply was lost."""
    from rclpy.action.client import ClientGoalHandle
    response = client._action_type.Impl.SendGoalService.Response(accepted=True, stamp=stamp)
    handle = ClientGoalHandle(client, goal_id, response)
    handle._status = status
    if not _ended(status):     # status updates reach it as they reach an answered goal's handle
        client._goal_handles[bytes(goal_id.uuid)] = weakref.ref(handle)
    return handle


def _forget(client, requests) -> None:
    """Drop the unanswered requests from rclpy's client: a late reply would be a second
    handle for one id (rclpy raises); forgotten, rclpy only warns."""
    forget = getattr(client, '_remove_pending_goal_request', None)
    for request in requests:
        if forget is not None and not request.done():
            forget(request)


def send_goal(client, goal, *, watch: GoalStatusWatch | None = None, wait: Wait = polling_wait,
              feedback=None, response_wait: float = GOAL_RESPONSE_WAIT):
    """Send goal through an rclpy ActionClient; its handle once answered or listed accepted
    (response_wait s per attempt; TimeoutError after GOAL_ATTEMPTS)."""
    from unique_identifier_msgs.msg import UUID
    watch = watch or GoalStatusWatch.of(client)
    goal_id = UUID(uuid=list(os.urandom(16)))
    key = bytes(goal_id.uuid)

    def listed() -> bool:
        return watch.get(key) is not None

    requests = []
    try:
        for attempt in range(GOAL_ATTEMPTS):
            try:
                sent = client.send_goal_async(goal, feedback_callback=feedback, goal_uuid=goal_id)
                requests.append(sent)
            except ValueError:
                # rclpy race: the answer came before send_goal_async registered its future
                sent = None
            handle = (sent.result() if sent is not None and wait(sent.done, response_wait)
                      and sent.done() else None)
            if handle is not None and (handle.accepted or attempt == 0):
                return handle            # the answer; a first rejection is a real one
            # No reply, or a repeat rejected (an id the server tracks): ask the status topic
            if wait(listed, STATUS_WAIT if handle is None else response_wait) and listed():
                return _adopted(client, goal_id, *watch.get(key))
            if handle is not None:
                return handle            # rejected, and never accepted
    finally:
        _forget(client, requests)
    raise TimeoutError(f'the action server answered none of {GOAL_ATTEMPTS} requests for one goal '
                       f'({response_wait:g} s each)')


def goal_result(handle, *, wait: Wait = polling_wait, watch: GoalStatusWatch | None = None):
    """The result response of an accepted goal (``.status``, ``.result``), asked again every
    RESULT_ASK_AGAIN s once the handle or status topic says it ended (RESULT_ASK_ANYWAY s in
    any case); None if a wait returns True first."""
    watch = watch or GoalStatusWatch.of(handle._action_client)
    key = bytes(handle.goal_id.uuid)

    def ended() -> bool:
        listed = watch.get(key)
        return _ended(handle.status) or (listed is not None and _ended(listed[0]))

    futures = [handle.get_result_async()]
    asked = time.monotonic()

    def answered() -> bool:
        return any(f.done() for f in futures)

    while not wait(answered, RESULT_ASK_AGAIN):
        if ended() or time.monotonic() - asked >= RESULT_ASK_ANYWAY:
            futures.append(handle.get_result_async())
            asked = time.monotonic()
    done = [f for f in futures if f.done()]
    return done[0].result() if done else None
