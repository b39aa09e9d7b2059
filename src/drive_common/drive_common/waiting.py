"""One waiting loop: poll a condition until it holds or a deadline passes."""
from __future__ import annotations

import threading
import time
from typing import Any, Callable


class WaitTimeout(TimeoutError):
    """A waited-for condition did not happen in time."""


def wait_until(predicate: Callable[[], Any], timeout: float, interval: float = 0.01,
               what: str = 'condition', *, pause: Callable[[float], Any] = time.sleep,
               raise_timeout: bool = True) -> Any:
    """Poll predicate (``pause(interval)`` between polls) until it returns a truthy value; that value.

    After timeout s, :class:`WaitTimeout` naming ``what`` (raise_timeout False: the last value).
    """
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > deadline:
            if not raise_timeout:
                return value
            raise WaitTimeout(f'timed out after {timeout:.1f} s waiting for {what}')
        pause(interval)


def future_result(future, timeout: float, what: str = 'answer') -> Any:
    """The result of a future that an executor spinning elsewhere completes; WaitTimeout
    naming ``what`` if it is not done within timeout s."""
    done = threading.Event()
    future.add_done_callback(lambda _f: done.set())
    if not done.wait(timeout):
        raise WaitTimeout(f'{what}: no answer within {timeout} s')
    return future.result()
