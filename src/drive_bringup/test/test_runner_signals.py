"""run_scenario's main takes a Ctrl-C as an interrupt (exit 130) wherever it lands, also inside
rclpy's C++ layer, where pybind11 turns the KeyboardInterrupt into a RuntimeError."""
import os
import signal
import time

import pytest

from drive_bringup import runner_cli


def _interrupted_inside_cpp(argv):
    """What rclpy's take_message does when the signal handler raises during its conversion."""
    try:
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(30)
    except KeyboardInterrupt:
        raise RuntimeError("Unable to convert call argument '0' to Python object") from None
    return 0


def test_an_interrupt_that_surfaces_as_a_runtime_error_still_ends_with_130(monkeypatch, capsys):
    monkeypatch.setattr(runner_cli, 'watch_starter', lambda: True)
    monkeypatch.setattr(runner_cli, '_main', _interrupted_inside_cpp)
    assert runner_cli.main([]) == 130
    assert 'interrupted: all nodes stopped' in capsys.readouterr().err
    assert signal.getsignal(signal.SIGINT) is not runner_cli._interrupt    # handlers restored


def test_a_runtime_error_without_a_signal_is_not_taken_for_an_interrupt(monkeypatch):
    def broken(argv):
        raise RuntimeError('a real bug')
    monkeypatch.setattr(runner_cli, 'watch_starter', lambda: True)
    monkeypatch.setattr(runner_cli, '_main', broken)
    with pytest.raises(RuntimeError, match='a real bug'):
        runner_cli.main([])
