"""Client side of the plant's ``plant/run`` action, safe against replies lost at start-up.

Right after discovery a reply can be lost: an action client sees the server
ready once the server's request readers have matched it, but the server's
reply writers may not have matched the client's reply readers yet, and Fast
DDS then drops the reply ("failed to send response (timeout)"). A Run goal
whose reply never comes would leave a client waiting forever. These helpers,
used by the scenario runner, the benchmarks and the tests, and meant for
launch-free user scripts too:

- :func:`send_run_goal` sends a goal to an absolute target again when no
  reply came within GOAL_RESPONSE_WAIT s;
- :func:`run_goal_result` asks again for the result of a goal whose status
  says it has ended;
- :func:`run_to` does both and bounds the whole run.

``wait(done, seconds)`` is how a helper waits: it must let the client's node
be spun (its executor elsewhere: :func:`polling_wait`, the default; or spin
it: ``lambda done, s: executor.spin_until_future_complete(...)``) and return
whether ``done()`` holds.
"""
from __future__ import annotations

import time
from typing import Any, Callable

from drive_common.waiting import WaitTimeout, wait_until
from dtc_msgs.action import Run

Wait = Callable[[Callable[[], bool], float], Any]

GOAL_RESPONSE_WAIT = 5.0   # s without a response after which a Run goal is sent again
GOAL_ATTEMPTS = 6
RESULT_ASK_AGAIN = 2.0     # s after which an ended goal's result is asked for again


def polling_wait(done: Callable[[], bool], seconds: float) -> bool:
    """Poll done() for up to seconds (the node is spun by an executor of its own)."""
    return bool(wait_until(done, seconds, 0.005, raise_timeout=False))


def send_run_goal(action, target: float, *, wait: Wait = polling_wait, feedback=None):
    """Send a plant/run goal to ``target`` s (absolute) until the plant answers; its goal handle.

    A goal unanswered for GOAL_RESPONSE_WAIT s is sent again. The lost one
    may still run; as targets are absolute, the one accepted ends at the same
    sample (while the lost one holds the plant the repeat is rejected, and
    sent again). A rejection of a first attempt is returned as it is;
    TimeoutError after GOAL_ATTEMPTS unanswered tries. (A relative goal is not
    offered: sent twice it would run twice.)
    """
    unanswered = 0
    while True:
        send = action.send_goal_async(Run.Goal(target_time=target, relative=False),
                                      feedback_callback=feedback)
        if wait(send.done, GOAL_RESPONSE_WAIT):
            handle = send.result()
            if handle.accepted or not unanswered:
                return handle
            wait(lambda: False, 0.2)        # a repeat while the lost goal still runs
        else:
            unanswered += 1
        if unanswered >= GOAL_ATTEMPTS:
            raise TimeoutError(f'the plant answered none of {GOAL_ATTEMPTS} Run goals to {target} s '
                               f'({GOAL_RESPONSE_WAIT:g} s each)')


def run_goal_result(handle, *, wait: Wait = polling_wait):
    """The result of an accepted plant/run goal (its ``Run.Result``).

    While the goal's status (the action's status topic, transient local) says
    it has ended and no result came, the result is asked for again every
    RESULT_ASK_AGAIN s. No overall timeout (the plant's own timeouts end
    every goal); a wait that returns True before the result came ends it with
    None.
    """
    from action_msgs.msg import GoalStatus
    ended = (GoalStatus.STATUS_SUCCEEDED, GoalStatus.STATUS_ABORTED, GoalStatus.STATUS_CANCELED)
    future = handle.get_result_async()
    while not wait(future.done, RESULT_ASK_AGAIN):
        if handle.status in ended:
            future = handle.get_result_async()
    return future.result().result if future.done() else None


def run_to(action, target: float, *, timeout: float = 120.0, wait: Wait = polling_wait):
    """Run the plant to absolute ``target`` s and return the ``Run.Result``.

    ValueError if the plant rejects the goal (another run holds it, a bad
    target); TimeoutError if it answers no goal (send_run_goal); WaitTimeout
    if no result came within timeout s (wall) of the goal's acceptance.
    """
    handle = send_run_goal(action, target, wait=wait)
    ends = time.monotonic() + timeout

    def bounded(done, seconds):
        return wait(done, max(0.0, min(seconds, ends - time.monotonic()))) or time.monotonic() > ends

    if not handle.accepted:
        raise ValueError(f'the plant rejected the Run goal to {target} s (see its log)')
    result = run_goal_result(handle, wait=bounded)
    if result is None:
        raise WaitTimeout(f'no result of the Run goal to {target} s within {timeout:g} s')
    return result
