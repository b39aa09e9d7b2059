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


OTHER_THREAD = textwrap.dedent('''
    import os, signal, threading
    from drive_common.node_main import stop_on_signals
    stop = threading.Event()
    threading.Thread(target=threading.Event().wait, daemon=True).start()   # takes the signal
    signal.pthread_sigmask(signal.SIG_BLOCK, {{signal.{name}}})  # main thread only: as if it
    stop_on_signals(stop)                 # had another signal pending, the kernel picks another
    os.kill(os.getpid(), signal.{name})
    print('stopped' if stop.wait(30.0) else 'not stopped', flush=True)
''')


@pytest.mark.parametrize('name', ['SIGINT', 'SIGTERM'])
def test_a_signal_taken_by_another_thread_stops_a_main_thread_blocked_on_the_stop_event(name):
    """Python runs its handlers in the main thread only; blocked in stop.wait() it would not
    wake for a signal the kernel gave another thread (the node would ignore SIGINT)."""
    done = subprocess.run([sys.executable, '-c', OTHER_THREAD.format(name=name)],
                          capture_output=True, text=True, timeout=120)
    assert (done.returncode, done.stdout.strip()) == (0, 'stopped'), done.stderr
