"""SIGINT/SIGTERM stop a node even when they arrive while its main thread waits on the stop
event (drive_common.node_main.stop_on_signals)."""
from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

PROGRAM = textwrap.dedent('''
    import os, signal, threading
    from drive_common.node_main import stop_on_signals
    stop = threading.Event()
    stop_on_signals(stop)
    with stop._cond:                      # as inside stop.wait(): the event's lock is held
        os.kill(os.getpid(), signal.{name})
        sum(range(1000))                  # bytecodes: the handler runs here, in this thread
    print('stopped' if stop.wait(30.0) else 'not stopped', flush=True)
''')


@pytest.mark.parametrize('name', ['SIGINT', 'SIGTERM'])
def test_a_signal_that_arrives_while_the_main_thread_holds_the_stop_event_still_stops(name):
    """A handler that set the event itself would deadlock on the held lock (the process hangs)."""
    done = subprocess.run([sys.executable, '-c', PROGRAM.format(name=name)], capture_output=True,
                          text=True, timeout=120)
    assert (done.returncode, done.stdout.strip()) == (0, 'stopped'), done.stderr
