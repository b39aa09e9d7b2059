"""A process started by drive_common.processes stops when the process that started it ends.

Started nodes and runners have their own session, so a starter killed by SIGKILL (or a
test worker that dies) cannot take them down with a signal; without this they would stay
in the graph, orphans that the next graph on their domain meets as a second graph.
The starter names itself in :data:`STARTER_PID_VARIABLE` (:func:`starter_env`); the
started process watches it with a pidfd (:func:`watch_starter`) and, when it has ended,
interrupts itself with SIGINT, so it stops as on Ctrl-C.
"""
from __future__ import annotations

import os
import select
import signal
import sys
import threading
from typing import Mapping

STARTER_PID_VARIABLE = 'DTC_STARTER_PID'


def starter_env(env: Mapping[str, str] | None = None) -> dict[str, str]:
    """env (default: this process's) naming this process as the starter."""
    return {**(os.environ if env is None else env), STARTER_PID_VARIABLE: str(os.getpid())}


def _say(text: str) -> None:
    print(f'[{os.path.basename(sys.argv[0]) or "process"}] {text}', file=sys.stderr, flush=True)


def watch_starter() -> bool:
    """SIGINT to this process once its starter (if named) has ended; False if it already has.

    A starter that cannot be watched (no pidfd on this kernel) is reported and not watched.
    """
    value = os.environ.get(STARTER_PID_VARIABLE, '')
    if not value.isdigit():
        return True
    try:
        starter = os.pidfd_open(int(value))
    except ProcessLookupError:
        _say(f'the process that started it (pid {value}) has already ended: not starting')
        return False
    except OSError as exc:
        _say(f'cannot watch the process that started it (pid {value}): {exc}; '
             'it stops only when that process stops it')
        return True

    def watch() -> None:
        select.select([starter], [], [])       # readable once the starter has exited
        _say(f'the process that started it (pid {value}) has ended: stopping')
        os.kill(os.getpid(), signal.SIGINT)
    threading.Thread(target=watch, daemon=True, name='starter_watch').start()
    return True
