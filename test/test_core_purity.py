"""Core modules are ROS-agnostic: importing any of them loads no rclpy.

Every module under a package's ``core/`` subpackage (and the pure helper
modules the cores share) is imported in a fresh interpreter; the test fails
if rclpy or any generated *_msgs package ends up in sys.modules, and the
controller cores must not import plant code.
"""
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / 'src'
PURE_SHARED = ['drive_common.parameters', 'drive_common.samples', 'drive_common.telemetry',
               'drive_common.controller_api',   # a user's core imports it; so is the example
               'drive_examples.hysteresis_current_controller']


def core_modules() -> list[str]:
    modules = list(PURE_SHARED)
    for core_dir in sorted(SRC.glob('*/*/core')):
        if not (core_dir / '__init__.py').exists():
            continue
        package_root = core_dir.parent.parent
        for path in sorted(core_dir.rglob('*.py')):
            rel = path.relative_to(package_root).with_suffix('')
            parts = list(rel.parts)
            if parts[-1] == '__init__':
                parts = parts[:-1]
            modules.append('.'.join(parts))
    return modules


CHECK = textwrap.dedent('''
    import importlib, sys
    name, forbidden_prefix = sys.argv[1], sys.argv[2]
    importlib.import_module(name)
    bad = sorted(m for m in sys.modules
                 if m == 'rclpy' or m.startswith('rclpy.') or m.split('.')[0].endswith('_msgs')
                 or m.split('.')[0] == 'rosidl_runtime_py'
                 or (forbidden_prefix and m.split('.')[0] == forbidden_prefix))
    if bad:
        print(name + ' imports ' + ', '.join(bad[:5]))
        sys.exit(1)
''')


def _check(module: str, forbidden: str = '') -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, '-c', CHECK, module, forbidden],
                          capture_output=True, text=True, timeout=60)


def test_the_check_catches_a_module_that_imports_rclpy(tmp_path, monkeypatch):
    (tmp_path / 'impure_core_probe.py').write_text('import rclpy\n')
    monkeypatch.setenv('PYTHONPATH', str(tmp_path))
    result = subprocess.run([sys.executable, '-c', CHECK, 'impure_core_probe', ''],
                            capture_output=True, text=True, timeout=60,
                            env={**__import__('os').environ, 'PYTHONPATH': str(tmp_path)})
    assert result.returncode == 1 and 'rclpy' in result.stdout


def test_core_modules_are_discovered():
    assert set(PURE_SHARED) <= set(core_modules())


@pytest.mark.parametrize('module', core_modules())
def test_core_module_imports_no_ros(module):
    forbidden = 'bldc_plant_sim' if module.startswith(('dtc_controller', 'pfc_controller')) else ''
    result = _check(module, forbidden)
    assert result.returncode == 0, result.stdout + result.stderr
