"""The one ``main`` of every executable: start a node, run it, stop it cleanly.

:func:`run_node`: a node that cannot start prints one line and exits 2; SIGINT/SIGTERM end
it with 0; an exception escaping any thread prints its traceback and exits 1. SIGUSR1
(:data:`STACK_DUMP_SIGNAL`) prints every thread's stack; a node stops when its starter ends.
"""
from __future__ import annotations

import faulthandler
import os
import signal
import sys
import threading
from typing import Callable

from drive_common.node_help import print_node_help, wants_help
from drive_common.parameter_files import ParameterFileError, params_files_in, read_params_file
from drive_common.parameters import ParameterError
from drive_common.starter import say, watch_starter


STACK_DUMP_SIGNAL = signal.SIGUSR1


def fail(reason: object, code: int = 2) -> int:
    """Print ``[program] error: reason`` on one line (stderr); return code."""
    say('error: ' + ' '.join(str(reason).split()))
    return code


def node_alive(node) -> bool:
    """Whether node's rcl handle is still valid (not destroyed, or destruction deferred)."""
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
    try:
        return bool(node.handle.pointer)
    except _rclpy.InvalidHandle:
        return False


def destroy_node_and_actions(node) -> None:
    """node.destroy_node(), then its action clients and servers (rclpy leaves them holding
    the rcl node until garbage-collected)."""
    waitables = list(node.waitables)
    node.destroy_node()
    for waitable in waitables:
        destroy = getattr(waitable, 'destroy', None)
        if destroy is not None:
            destroy()


def spin_in_background(executor, name: str = 'executor',
                       on_refusal: Callable[[ParameterError], None] | None = None) -> threading.Thread:
    """A started daemon thread spinning executor until it or its context shuts down; an entity
    destroyed meanwhile (InvalidHandle) does not end it. on_refusal(ParameterError): called
    with a callback's refusal (e.g. GraphConflict), which ends the thread; else it propagates.
    """
    from rclpy.executors import ExternalShutdownException
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy

    def spin() -> None:
        while True:
            try:
                executor.spin()
                return
            except ExternalShutdownException:
                return
            except ParameterError as exc:
                if on_refusal is None:
                    raise
                on_refusal(exc)
                return
            except _rclpy.RCLError:
                if not executor.context.ok():   # shut down while the wait set was built
                    return
                raise
            except _rclpy.InvalidHandle:
                for node in executor.get_nodes():      # a destroyed node is waited on no more
                    if not node_alive(node):
                        executor.remove_node(node)
            except AttributeError:
                # rclpy's shutdown() from another thread sets the executor's guard condition
                # to None while this thread builds its wait set (ros2/rclpy#968): shut down
                if getattr(executor, '_guard', True) is None:
                    return
                raise
    thread = threading.Thread(target=spin, daemon=True, name=name)
    thread.start()
    return thread


def stop_on_signals(stop: threading.Event, signals=(signal.SIGINT, signal.SIGTERM)) -> None:
    """SIGINT/SIGTERM set ``stop``, from a relay thread reading :func:`signal.set_wakeup_fd`'s
    pipe (a signal delivered to another thread would never wake a main thread in
    ``stop.wait()``, and setting the event in a handler could deadlock). Main thread only.
    """
    read_fd, write_fd = os.pipe()
    os.set_blocking(write_fd, False)
    wanted = {int(sig) for sig in signals}

    def relay() -> None:
        while not wanted.intersection(os.read(read_fd, 64)):   # bytes: signal numbers
            pass
        stop.set()
    threading.Thread(target=relay, daemon=True, name='signal_relay').start()
    for sig in signals:
        signal.signal(sig, lambda *_: None)        # the wakeup byte does the work
    signal.set_wakeup_fd(write_fd, warn_on_full_buffer=False)


def run_node(factory: Callable[[], object], args=None, *, multithreaded: bool = False,
             work: Callable[[object, threading.Event], None] | None = None,
             errors: tuple[type[BaseException], ...] = (), about: object | None = None) -> int:
    """Run the node built by ``factory`` until SIGINT/SIGTERM (or ``work`` returns); exit code.

    multithreaded: a 4-thread executor; work(node, stop): runs in the main thread; errors:
    more "cannot start" types (exit 2); about: what ``--help`` describes (default: factory).
    """
    argv = sys.argv if args is None else args
    if wants_help(argv):
        return print_node_help(about if about is not None else factory)
    import rclpy
    from rclpy.exceptions import ParameterException
    from rclpy.executors import MultiThreadedExecutor, SingleThreadedExecutor
    from rclpy.signals import SignalHandlerOptions

    try:
        for path in params_files_in(argv):
            read_params_file(path)
    except ParameterFileError as exc:
        return fail(exc)
    faulthandler.register(STACK_DUMP_SIGNAL, all_threads=True)
    stop = threading.Event()
    stop_on_signals(stop)
    if not watch_starter():
        return 0
    try:
        rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    except Exception as exc:  # noqa: BLE001 - rcl's own errors: bad --ros-args / params file
        return fail(f'bad ROS arguments: {exc}')
    node = None
    report_thread_error = threading.excepthook
    try:
        try:
            node = factory()
        except (ParameterError, ParameterException, OSError, *errors) as exc:
            return fail(f'cannot start: {exc}')
        executor = MultiThreadedExecutor(num_threads=4) if multithreaded else SingleThreadedExecutor()
        executor.add_node(node)

        failures: list[tuple[BaseException, int]] = []     # (error, exit code)

        def crashed(hook_args) -> None:
            report_thread_error(hook_args)                 # the traceback, as Python prints it
            if not stop.is_set() and isinstance(hook_args.exc_value, Exception):
                failures.append((hook_args.exc_value, 1))  # a bug, not a shutdown race
                stop.set()

        threading.excepthook = crashed

        def refused(exc: ParameterError) -> None:     # raised by a callback, e.g. GraphConflict
            failures.append((exc, 2))
            stop.set()

        spinner = spin_in_background(executor, on_refusal=refused)
        if work is None:
            stop.wait()
        else:
            try:
                work(node, stop)
            except ParameterError as exc:    # e.g. GraphConflict found by the node's own loop
                failures.append((exc, 2))
        stop.set()                              # from here on a thread's error is a shutdown race
        getattr(node, 'stop', lambda: None)()   # end the node's own threads while the context lives
        rclpy.try_shutdown()          # ends a running action loop and the executor
        executor.shutdown(timeout_sec=2.0)
        spinner.join(timeout=2.0)
        if failures:
            error, code = failures[0]
            return fail(error if code == 2 else f'{type(error).__name__}: {error} (traceback above)', code)
    finally:
        threading.excepthook = report_thread_error
        if node is not None:
            destroy_node_and_actions(node)
        rclpy.try_shutdown()
    return 0
