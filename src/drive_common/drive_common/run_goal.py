"""Client side of the plant's ``plant/run`` action, for runners, benchmarks, tests and scripts.

Lost replies are recovered as in :mod:`drive_common.action_goals` (a goal never runs twice);
``wait(done, seconds)`` as there.
"""
from __future__ import annotations

from drive_common.action_goals import GoalStatusWatch, Wait, goal_result, polling_wait, send_goal, within
from drive_common.waiting import WaitTimeout
from dtc_msgs.action import Run


def send_run_goal(action, target: float, *, relative: bool = False, wait: Wait = polling_wait,
                  feedback=None, watch: GoalStatusWatch | None = None):
    """Send a plant/run goal to ``target`` s (relative: from the plant's time); its goal handle
    (accepted or not). TimeoutError if the plant answers none of the attempts."""
    return send_goal(action, Run.Goal(target_time=target, relative=relative), watch=watch, wait=wait,
                     feedback=feedback)


def run_goal_result(handle, *, wait: Wait = polling_wait):
    """The ``Run.Result`` of an accepted plant/run goal; None if a wait returned True before it came.
    No overall timeout: the plant's own timeouts end every goal."""
    response = goal_result(handle, wait=wait)
    return None if response is None else response.result


def run_to(action, target: float, *, relative: bool = False, timeout: float = 120.0,
           wait: Wait = polling_wait):
    """Run the plant to ``target`` s and return the ``Run.Result``: ValueError if rejected,
    TimeoutError if unanswered, WaitTimeout if no result within timeout s (wall)."""
    handle = send_run_goal(action, target, relative=relative, wait=wait)
    if not handle.accepted:
        raise ValueError(f'the plant rejected the Run goal to {target} s (see its log)')
    result = run_goal_result(handle, wait=within(wait, timeout))
    if result is None:
        raise WaitTimeout(f'no result of the Run goal to {target} s within {timeout:g} s')
    return result
