"""A process started by drive_common.processes stops (SIGINT to itself) when its starter ends,
even SIGKILLed: the starter names itself in :data:`STARTER_PID_VARIABLE`, the started process
watches it with a pidfd. Else orphans would stay in the graph as a second graph."""
from __future__ import annotations

import os
import select
import signal
import sys
import threading
from typing import Mapping

STARTER_PID_VARIABLE = 'DTC_STARTER_PID'


def proc_stat(pid: int) -> list[str] | None:
    """Fields 3 on of /proc/PID/stat (after the command name); None if the process is gone."""
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
    """env (default: this process's) naming this process as the starter, ``pid:start_time``."""
    pid, started = os.getpid(), start_time(os.getpid())
    value = f'{pid}:{started}' if started else str(pid)      # (no /proc: the pid alone)
    return {**(os.environ if env is None else env), STARTER_PID_VARIABLE: value}


def say(text: str) -> None:
    """Print ``[program] text`` on stderr: how a node or runner reports before ROS logging is up."""
    print(f'[{os.path.basename(sys.argv[0]) or "node"}] {text}', file=sys.stderr, flush=True)


def watch_starter() -> bool:
    """SIGINT to this process once its starter (if named) has ended; False if it already has."""
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
    # another start time: the starter's pid went to a new process before the pidfd was opened
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
