"""NodeProcess keeps a node's output for the caller and leaves no temporary folder behind."""
from __future__ import annotations

import sys

from drive_common.processes import NodeProcess


def test_a_stopped_node_keeps_its_output_and_removes_its_temporary_log_folder():
    node = NodeProcess('none', 'echo_node', argv=[sys.executable, '-c', 'print("said this")'])
    folder = node.log_path.parent
    assert node.process.wait(timeout=60) == 0
    assert node.stop() == 0
    assert not folder.exists()
    assert 'said this' in node.output()
    assert node.stop() == 0 and 'said this' in node.output()     # a second stop changes nothing


def test_a_given_log_folder_is_kept(tmp_path):
    with NodeProcess('none', 'echo_node', argv=[sys.executable, '-c', 'print("kept")'],
                     log_dir=tmp_path) as node:
        node.process.wait(timeout=60)
    assert (tmp_path / 'echo_node.log').read_text().strip() == 'kept'
    assert node.output().strip() == 'kept'
