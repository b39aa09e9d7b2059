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


def proc_stat(pid: int) -> list[str] | None:
    """Fields 3 on of /proc/PID/stat (state, ppid, ..., ``[19]`` start time), after the
    parenthesised command name (which may hold spaces); None if the process is gone."""
    try:
        with open(f'/proc/{pid}/stat') as stat:
            return stat.read().rsplit(')', 1)[1].split()
    except (OSError, IndexError):
        return None


def start_time(pid: int) -> str | None:
    """When process pid started (clock ticks since boot, /proc/PID/stat field 22); None if gone."""
    fields = proc_stat(pid)
    return fields[19] if fields and len(fields) > 19 else None


def starter_env(env: Mapping[str, str] | None = None) -> dict[str, str]:
    """env (default: this process's) naming this process as the starter: ``pid:start_time``
    (a bare pid is accepted too), so a pid taken over by a new process is not mistaken for it."""
    pid, started = os.getpid(), start_time(os.getpid())
    value = f'{pid}:{started}' if started else str(pid)      # (no /proc: the pid alone)
    return {**(os.environ if env is None else env), STARTER_PID_VARIABLE: value}


def say(text: str) -> None:
    """Print ``[program] text`` on stderr: how a node or runner reports before ROS logging is up."""
    print(f'[{os.path.basename(sys.argv[0]) or "node"}] {text}', file=sys.stderr, flush=True)


def watch_starter() -> bool:
    """SIGINT to this process once its starter (if named) has ended; False if it already has.

    A starter that cannot be watched (no pidfd on this kernel) is reported and not watched.
    """
    value, _, started = os.environ.get(STARTER_PID_VARIABLE, '').partition(':')
    if not value.isdigit():
        return True
    try:
        starter = os.pidfd_open(int(value))
    except ProcessLookupError:
        starter = None
    except OSError as exc:
        say(f'cannot watch the process that started it (pid {value}): {exc}; '
            'it stops only when that process stops it')
        return True
    # the pidfd holds the process it was opened on: a start time that differs now means the
    # starter had ended and its pid went to another process before the pidfd was opened
    if starter is None or (started and start_time(int(value)) != started):
        if starter is not None:
            os.close(starter)
        say(f'the process that started it (pid {value}) has already ended: not starting')
        return False

    def watch() -> None:
        select.select([starter], [], [])       # readable once the starter has exited
        say(f'the process that started it (pid {value}) has ended: stopping')
        os.kill(os.getpid(), signal.SIGINT)
    threading.Thread(target=watch, daemon=True, name='starter_watch').start()
    return True
