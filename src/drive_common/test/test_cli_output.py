"""A CLI whose reader closed the pipe (``... | head``) ends quietly, without a traceback."""
import os
import subprocess
import sys

import pytest

from drive_common.cli_output import CLOSED_PIPE_EXIT


@pytest.mark.parametrize('command', [
    ['drive_bringup.runner_cli', '--list'],        # run_scenario --list
    ['drive_ros2cli.cli', 'interface', 'list'],    # the embedded ros2 (upstream: code 0)
])
def test_a_closed_pipe_ends_the_cli_quietly(command):
    read_end, write_end = os.pipe()
    os.close(read_end)                  # the reader is gone before the first write
    try:
        done = subprocess.run([sys.executable, '-m', *command], stdout=write_end,
                              stderr=subprocess.PIPE, text=True, timeout=120)
    finally:
        os.close(write_end)
    assert 'Traceback' not in done.stderr, done.stderr
    expected = 0 if command[0] == 'drive_ros2cli.cli' else CLOSED_PIPE_EXIT
    assert done.returncode == expected, done.stderr
