"""Command-line output that a closed pipe does not turn into a traceback (no rclpy)."""
from __future__ import annotations

import functools
import os
import signal
import sys
from typing import Callable

CLOSED_PIPE_EXIT = 128 + signal.SIGPIPE
"""Exit code when the reader of stdout went away (``... | head``), as for a tool SIGPIPE ended."""


def quiet_on_closed_pipe(main: Callable[..., int]) -> Callable[..., int]:
    """Wrap a CLI main: a reader that closed stdout ends it quietly with :data:`CLOSED_PIPE_EXIT`."""
    @functools.wraps(main)
    def wrapped(*args, **kwargs) -> int:
        try:
            return main(*args, **kwargs)
        except BrokenPipeError:
            silence_stdout()
            return CLOSED_PIPE_EXIT
    return wrapped


def silence_stdout() -> None:
    """Send stdout to /dev/null (its reader went away): Python's final flush then does not raise."""
    os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
