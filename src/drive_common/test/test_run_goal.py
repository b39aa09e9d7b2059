"""A Run goal whose reply or result is lost right after discovery is asked for again (drive_common.run_goal)."""
from __future__ import annotations

import pytest

from drive_common import run_goal
from drive_common.run_goal import run_goal_result, run_to, send_run_goal


class _Future:
    def __init__(self, handle=None) -> None:
        self._handle = handle

    def done(self) -> bool:
        return self._handle is not None

    def result(self):
        return self._handle


class _Handle:
    def __init__(self, accepted: bool) -> None:
        self.accepted = accepted


class _Action:
    """Answers goals from a script: None = the response is lost, else accepted or not."""

    def __init__(self, *answers) -> None:
        self.answers = list(answers)
        self.goals = []

    def send_goal_async(self, goal, feedback_callback=None):
        self.goals.append(goal)
        answer = self.answers.pop(0)
        return _Future(None if answer is None else _Handle(answer))


def _wait(done, timeout):
    return done()      # the scripted futures are answered at once or never


def test_an_answered_goal_is_sent_once():
    action = _Action(True)
    assert send_run_goal(action, 0.25, wait=_wait).accepted
    assert len(action.goals) == 1
    assert action.goals[0].target_time == 0.25 and not action.goals[0].relative


def test_a_goal_without_response_is_sent_again_to_the_same_absolute_target():
    action = _Action(None, None, True)
    assert send_run_goal(action, 0.5, wait=_wait).accepted
    assert [g.target_time for g in action.goals] == [0.5, 0.5, 0.5]
    assert not any(g.relative for g in action.goals)


def test_a_repeat_rejected_while_the_lost_goal_runs_is_sent_again():
    action = _Action(None, False, False, True)
    assert send_run_goal(action, 0.5, wait=_wait).accepted
    assert len(action.goals) == 4


def test_a_first_rejection_is_returned_not_repeated():
    action = _Action(False, True)
    assert not send_run_goal(action, 0.5, wait=_wait).accepted
    assert len(action.goals) == 1


def test_a_plant_that_never_answers_fails_with_the_count(monkeypatch):
    monkeypatch.setattr(run_goal, 'GOAL_ATTEMPTS', 3)
    action = _Action(None, None, None, True)
    with pytest.raises(TimeoutError, match='answered none of 3 Run goals to 0.5 s'):
        send_run_goal(action, 0.5, wait=_wait)
    assert len(action.goals) == 3


class _ResultHandle:
    """A goal handle whose first result replies are lost; status as the status topic says."""

    def __init__(self, lost: int, status: int) -> None:
        self.lost, self.status, self.asked = lost, status, 0

    def get_result_async(self):
        self.asked += 1
        if self.asked <= self.lost:
            return _Future(None)
        result = type('Response', (), {'result': 'the Run.Result'})()
        return _Future(result)


def test_a_lost_result_is_asked_again_once_the_goal_has_ended():
    from action_msgs.msg import GoalStatus
    handle = _ResultHandle(lost=2, status=GoalStatus.STATUS_SUCCEEDED)
    assert run_goal_result(handle, wait=_wait) == 'the Run.Result'
    assert handle.asked == 3


def test_a_running_goal_is_not_asked_again_and_a_wait_that_gives_up_gets_none():
    from action_msgs.msg import GoalStatus
    handle = _ResultHandle(lost=1, status=GoalStatus.STATUS_EXECUTING)
    waits = []

    def give_up_third_time(done, timeout):
        waits.append(timeout)
        return done() or len(waits) >= 3

    assert run_goal_result(handle, wait=give_up_third_time) is None
    assert handle.asked == 1 and waits == [run_goal.RESULT_ASK_AGAIN] * 3


class _RunAction:
    """Accepts (or rejects) every goal; its handles lose the first `lost` result replies."""

    def __init__(self, accept: bool, lost: int, status: int) -> None:
        self.accept, self.lost, self.status = accept, lost, status

    def send_goal_async(self, goal, feedback_callback=None):
        handle = _ResultHandle(self.lost, self.status)
        handle.accepted = self.accept
        return _Future(handle)


def test_run_to_returns_the_result_of_the_goal():
    from action_msgs.msg import GoalStatus
    assert run_to(_RunAction(True, 1, GoalStatus.STATUS_SUCCEEDED), 0.1, wait=_wait) == 'the Run.Result'


def test_run_to_refuses_a_rejected_goal():
    from action_msgs.msg import GoalStatus
    with pytest.raises(ValueError, match='rejected the Run goal to 0.1 s'):
        run_to(_RunAction(False, 0, GoalStatus.STATUS_UNKNOWN), 0.1, wait=_wait)


def test_run_to_gives_up_on_a_result_that_never_comes():
    from action_msgs.msg import GoalStatus
    from drive_common.waiting import WaitTimeout
    with pytest.raises(WaitTimeout, match='no result of the Run goal to 0.1 s within 0.05 s'):
        run_to(_RunAction(True, 10**9, GoalStatus.STATUS_EXECUTING), 0.1, timeout=0.05)
