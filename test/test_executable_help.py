"""Every console entry point of every package answers -h/--help with its usage and exit 0,
and starts nothing (no node, no child process left)."""
from __future__ import annotations

import os
import re
import signal
import subprocess
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from drive_common.processes import executable_path
from drive_testing.harness import isolated_env

pytestmark = pytest.mark.ros

SRC = Path(__file__).resolve().parents[1] / 'src'
ENTRY = re.compile(r"""['"]\s*([A-Za-z_][\w-]*)\s*=\s*[\w.]+:\w+\s*['"]""")


def console_scripts() -> list[tuple[str, str]]:
    """(package, executable) of every console_scripts entry in src/*/setup.py."""
    out = []
    for setup in sorted(SRC.glob('*/setup.py')):
        text = setup.read_text()
        if 'console_scripts' in text:
            block = text[text.index('console_scripts'):]
            block = block[:block.index(']')]
            out += [(setup.parent.name, name) for name in ENTRY.findall(block)]
    return out


SCRIPTS = console_scripts()
NODES = {'plant', 'dtc_controller', 'pfc_controller', 'recorder', 'replay', 'live_view'}


def _help(package: str, executable: str, flag: str, domain: int) -> tuple[int, str, bool]:
    """(exit code, stdout + stderr, whether any process of its group outlived it)."""
    process = subprocess.Popen([str(executable_path(package, executable)), flag],
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                               env=isolated_env(domain), start_new_session=True)
    try:
        output, _ = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            process.kill()
    try:
        os.killpg(process.pid, 0)
        left = True
        os.killpg(process.pid, signal.SIGKILL)
    except ProcessLookupError:
        left = False
    return process.returncode, output, left


def test_every_package_has_its_entry_points_listed():
    names = {name for _, name in SCRIPTS}
    assert NODES | {'export', 'reindex', 'compare_replay', 'analyze', 'run_scenario', 'reproduce',
                    'study', 'backemf_generator', 'hysteresis_current_controller',
                    'message_echo', 'fixed_responder'} <= names, sorted(names)


@pytest.mark.parametrize('flag', ['--help', '-h'])
def test_every_executable_prints_its_usage_and_starts_nothing(flag, ros_domain):
    with ThreadPoolExecutor(max_workers=2) as pool:
        results = dict(zip(SCRIPTS, pool.map(lambda s: _help(*s, flag, ros_domain), SCRIPTS)))
    for (package, executable), (code, output, left) in results.items():
        where = f'{package} {executable} {flag}'
        assert code == 0, f'{where}: exit {code}\n{output}'
        assert 'usage' in output.lower() and len(output.strip().splitlines()) >= 1, f'{where}: {output!r}'
        assert 'Traceback' not in output and not left, f'{where}: {output}'
        assert 'ready' not in output and '[INFO]' not in output, f'{where} started: {output}'


@pytest.mark.parametrize('executable', sorted(NODES))
def test_node_help_lists_its_schema_parameters_with_units_and_defaults(executable, ros_domain):
    from drive_common.node_help import schema_of
    import importlib
    package = dict((e, p) for p, e in SCRIPTS)[executable]
    code, output, _ = _help(package, executable, '--help', ros_domain)
    assert code == 0, output
    assert f'usage: ros2 run {package} {executable}' in output and '--ros-args' in output
    module = {'plant': 'bldc_plant_sim.plant_node', 'dtc_controller': 'dtc_controller.dtc_node',
              'pfc_controller': 'pfc_controller.pfc_node', 'recorder': 'drive_logger.recorder_node',
              'replay': 'drive_logger.replay_node', 'live_view': 'drive_logger.live_view'}[executable]
    node_class = {'plant': 'PlantNode', 'dtc_controller': 'DtcControllerNode',
                  'pfc_controller': 'PfcControllerNode', 'recorder': 'RecorderNode',
                  'replay': 'ReplayNode', 'live_view': 'LiveViewNode'}[executable]
    schema = schema_of(getattr(importlib.import_module(module), node_class))
    assert schema is not None and schema.specs
    for spec in schema.specs:
        line = next((ln for ln in output.splitlines() if ln.startswith(f'  {spec.name} (')), None)
        assert line is not None, f'{spec.name} missing:\n{output}'
        assert f'default {spec.default!r}' in line and (not spec.unit or spec.unit in line), line


def test_help_flag_counts_only_before_ros_args():
    from drive_common.node_help import wants_help
    assert wants_help(['plant', '--help']) and wants_help(['plant', '-h', '--ros-args', '-p', 'a:=1'])
    assert not wants_help(['plant', '--ros-args', '-p', 'help:=1'])
    assert not wants_help(['plant', '--ros-args', '-r', '__node:=x', '-h'])
    assert not wants_help(['plant'])
