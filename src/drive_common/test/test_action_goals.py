"""Goals whose reply is lost right after discovery are recovered and never run twice
(drive_common.action_goals, drive_common.run_goal), against a scripted server."""
from __future__ import annotations

import pytest
from action_msgs.msg import GoalStatus

from drive_common import action_goals
from drive_common.action_goals import goal_result
from drive_common.run_goal import run_to, send_run_goal
from drive_common.waiting import WaitTimeout
from dtc_msgs.action import Run


class _Future:
    def __init__(self, value=None) -> None:
        self._value = value

    def done(self) -> bool:
        return self._value is not None

    def result(self):
        return self._value


class _Listed:
    """A status topic that lists every goal with one status (None: lists nothing)."""

    def __init__(self, status: int | None = None) -> None:
        self.status = status

    def get(self, key: bytes):
        return None if self.status is None else (self.status, None)


class _Handle:
    """A goal handle whose first `lost` result replies are lost; `listed`: what the action's
    status topic says of it (its own status may have missed the goal's end)."""

    def __init__(self, accepted: bool, status: int = GoalStatus.STATUS_EXECUTING, lost: int = 0,
                 listed: int | None = None) -> None:
        from unique_identifier_msgs.msg import UUID
        self.accepted, self.status, self.lost, self.asked = accepted, status, lost, 0
        self.goal_id = UUID(uuid=[7] * 16)
        self._action_client = type('Client', (), {'_drive_status_watch': _Listed(listed)})()

    def get_result_async(self):
        self.asked += 1
        if self.asked <= self.lost:
            return _Future(None)
        return _Future(type('Response', (), {'status': self.status, 'result': 'the Run.Result'})())


class _Server:
    """An action client and the server behind it, from a script of (accepts, reply lost) per
    request. A request whose id the server already tracks is rejected, as rclpy's server does."""

    _action_type = Run

    def __init__(self, *script, listed_after: int = 1) -> None:
        self.script, self.listed_after = list(script), listed_after
        self.requests: list[tuple[object, bytes]] = []
        self.tracked: dict[bytes, int] = {}       # accepted goal ids (what would run)
        self._goal_handles: dict = {}

    def send_goal_async(self, goal, feedback_callback=None, goal_uuid=None):
        key = bytes(goal_uuid.uuid)
        self.requests.append((goal, key))
        accepts, lost = self.script.pop(0)
        accepted = accepts and key not in self.tracked
        if accepted:
            self.tracked[key] = GoalStatus.STATUS_EXECUTING
        return _Future(None if lost else _Handle(accepted))


class _Watch:
    """The status topic: lists the tracked goals once `listed_after` requests were sent."""

    def __init__(self, server: _Server) -> None:
        self.server = server

    def get(self, key: bytes):
        if len(self.server.requests) < self.server.listed_after or key not in self.server.tracked:
            return None
        from builtin_interfaces.msg import Time
        return self.server.tracked[key], Time(sec=1)


def _wait(done, timeout):
    return done()      # the scripted futures are answered at once or never


def _send(server, target=0.25, relative=False):
    return send_run_goal(server, target, relative=relative, wait=_wait, watch=_Watch(server))


def test_an_answered_goal_is_sent_once():
    server = _Server((True, False))
    assert _send(server).accepted
    (goal, _), = server.requests
    assert goal.target_time == 0.25 and not goal.relative


def test_an_accepted_goal_whose_reply_is_lost_is_taken_from_the_status_never_sent_again():
    server = _Server((True, True))
    handle = _send(server, 0.001, relative=True)         # relative: sent twice it would run twice
    assert handle.accepted and handle.status == GoalStatus.STATUS_EXECUTING
    assert len(server.requests) == 1 and len(server.tracked) == 1
    assert bytes(handle.goal_id.uuid) in server._goal_handles    # status updates reach it


class _RacingClient(_Server):
    """rclpy's race: the request goes out and is answered, then send_goal_async raises."""

    def send_goal_async(self, goal, feedback_callback=None, goal_uuid=None):
        super().send_goal_async(goal, feedback_callback, goal_uuid)
        raise ValueError('list.remove(x): x not in list')


def test_a_goal_whose_send_raced_with_its_answer_is_taken_from_the_status_never_sent_again():
    server = _RacingClient((True, False))
    handle = _send(server, 0.001, relative=True)
    assert handle.accepted and len(server.requests) == 1 and len(server.tracked) == 1


def test_a_request_neither_answered_nor_listed_is_sent_again_with_the_same_id():
    server = _Server((False, True), (True, False))        # rejected with its reply lost, then accepted
    assert _send(server).accepted
    assert len(server.requests) == 2 and server.requests[0][1] == server.requests[1][1]


def test_a_status_that_lists_the_goal_late_still_prevents_a_second_run():
    # The reply is lost and the status lists the goal only after the repeat, which the
    # server rejects as a duplicate id: the goal is the accepted one, and ran once.
    server = _Server((True, True), (True, False), listed_after=2)
    handle = _send(server, 0.001, relative=True)
    assert handle.accepted and len(server.tracked) == 1 and len(server.requests) == 2


def test_a_first_rejection_is_returned_not_repeated():
    server = _Server((False, False), (True, False))
    assert not _send(server).accepted
    assert len(server.requests) == 1


def test_a_repeat_rejected_for_another_reason_is_a_rejection():
    server = _Server((False, True), (False, False))       # never accepted
    assert not _send(server).accepted
    assert not server.tracked and len(server.requests) == 2


def test_a_server_that_never_answers_fails_with_the_count(monkeypatch):
    monkeypatch.setattr(action_goals, 'GOAL_ATTEMPTS', 3)
    server = _Server((False, True), (False, True), (False, True), (True, False))
    with pytest.raises(TimeoutError, match='answered none of 3 requests'):
        _send(server)
    assert len(server.requests) == 3


def test_a_lost_result_is_asked_again_once_the_goal_has_ended():
    handle = _Handle(True, GoalStatus.STATUS_SUCCEEDED, lost=2)
    assert goal_result(handle, wait=_wait).result == 'the Run.Result'
    assert handle.asked == 3


def test_a_running_goal_is_not_asked_again_and_a_wait_that_gives_up_gets_none():
    handle = _Handle(True, GoalStatus.STATUS_EXECUTING, lost=1)
    waits = []

    def give_up_third_time(done, timeout):
        waits.append(timeout)
        return done() or len(waits) >= 3

    assert goal_result(handle, wait=give_up_third_time) is None
    assert handle.asked == 1 and waits == [action_goals.RESULT_ASK_AGAIN] * 3


def test_a_lost_result_is_asked_again_when_only_the_status_topic_saw_the_goal_end():
    # A short goal's final status came before its goal reply: the handle missed it (rclpy
    # registers the handle only then), but the status topic lists the goal as succeeded.
    handle = _Handle(True, GoalStatus.STATUS_ACCEPTED, lost=1, listed=GoalStatus.STATUS_SUCCEEDED)
    assert goal_result(handle, wait=_wait).result == 'the Run.Result'
    assert handle.asked == 2


def test_a_result_is_asked_again_anyway_when_no_status_says_the_goal_ended(monkeypatch):
    monkeypatch.setattr(action_goals, 'RESULT_ASK_ANYWAY', 0.0)
    handle = _Handle(True, GoalStatus.STATUS_EXECUTING, lost=2)
    assert goal_result(handle, wait=_wait).result == 'the Run.Result'
    assert handle.asked == 3


class _RunServer(_Server):
    """Accepts (or rejects) every goal; its handles lose the first `lost` result replies."""

    def __init__(self, accept: bool, lost: int, status: int) -> None:
        super().__init__()
        self.accept, self.lost, self.status = accept, lost, status
        self._drive_status_watch = _Watch(self)

    def send_goal_async(self, goal, feedback_callback=None, goal_uuid=None):
        self.requests.append((goal, bytes(goal_uuid.uuid)))
        return _Future(_Handle(self.accept, self.status, self.lost))


def test_run_to_returns_the_result_of_the_goal():
    assert run_to(_RunServer(True, 1, GoalStatus.STATUS_SUCCEEDED), 0.1, wait=_wait) == 'the Run.Result'


def test_run_to_refuses_a_rejected_goal():
    with pytest.raises(ValueError, match='rejected the Run goal to 0.1 s'):
        run_to(_RunServer(False, 0, GoalStatus.STATUS_UNKNOWN), 0.1, wait=_wait)


def test_run_to_gives_up_on_a_result_that_never_comes():
    with pytest.raises(WaitTimeout, match='no result of the Run goal to 0.1 s within 0.05 s'):
        run_to(_RunServer(True, 10**9, GoalStatus.STATUS_EXECUTING), 0.1, timeout=0.05)


def test_a_reply_that_comes_after_the_goal_was_taken_from_its_status_is_ignored():
    """A runner stopped for a while (SIGSTOP, a starved machine) takes its goal from the status
    topic; the reply, taken later, must not make rclpy's client raise in the executor."""
    import rclpy
    from builtin_interfaces.msg import Time
    from rclpy.action import ActionClient
    from rclpy.context import Context

    from drive_common.processes import reserve_domain

    context = Context()
    with reserve_domain() as domain_id:
        rclpy.init(context=context, domain_id=domain_id)    # nothing spins it: the test does
        try:
            _late_reply(ActionClient(rclpy.create_node('late_reply_client', context=context), Run,
                                     'no_server/run'), Time)
        finally:
            rclpy.shutdown(context=context)


def _late_reply(client, Time) -> None:
    sequence_numbers = []
    send_goal_async = client.send_goal_async

    def send(*args, **kwargs):
        future = send_goal_async(*args, **kwargs)
        sequence_numbers.extend(n for n, f in client._pending_goal_requests.items() if f is future)
        return future
    client.send_goal_async = send
    listed = type('Listed', (), {'get': lambda self, key: (GoalStatus.STATUS_EXECUTING, Time(sec=1))})()
    handle = action_goals.send_goal(client, Run.Goal(target_time=0.1), watch=listed,
                                    wait=lambda done, seconds: done())
    assert handle.accepted and len(sequence_numbers) == 1
    late = client.execute({'goal': (sequence_numbers[0], Run.Impl.SendGoalService.Response(accepted=True))})
    with pytest.raises(StopIteration):
        late.send(None)                  # the executor's step: no RuntimeError
    assert client._goal_handles[bytes(handle.goal_id.uuid)]() is handle
