"""Start drive nodes as ``ros2 run`` does, each graph in its own DDS domain.

:func:`reserve_domain` hands out a ROS_DOMAIN_ID no other process here holds (a file
lock per id); :func:`graph_lock` lets one runner at a time drive a graph in a domain;
:class:`NodeProcess` runs a node in its own process group and always tears it down.
"""
from __future__ import annotations

import fcntl
import json
import os
import random
import shutil
import signal
import subprocess
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Iterator, Mapping, Sequence

from drive_common.node_main import STACK_DUMP_SIGNAL
from drive_common.starter import starter_env
from drive_common.waiting import wait_until

STACK_DUMP_MARK = '(most recent call first)'   # faulthandler's line per thread

DOMAIN_RANGE = range(1, 101)
DOMAIN_COOLDOWN = 60.0   # s a released domain id rests before it is handed out again
# Machine-wide, as the domain ids are (not under TMPDIR, which a caller may set per run).
_LOCK_DIR = Path('/tmp/dtc_drive_ros_domains')
_KEPT: dict[int, int] = {}   # domain id -> lock descriptor, held until this process exits


def catches_signal(pid: int, sig: int) -> bool:
    """Whether process pid has a handler for sig (Linux: SigCgt of /proc/pid/status)."""
    try:
        with open(f'/proc/{pid}/status') as status:
            for line in status:
                if line.startswith('SigCgt:'):
                    return bool(int(line.split()[1], 16) >> (sig - 1) & 1)
    except OSError:
        pass
    return False


def keep_reserved(domain_id: int) -> None:
    """Hold domain_id's reservation until this process exits, not just its
    :func:`reserve_domain` block (a participant here may outlive the block)."""
    _KEPT.setdefault(domain_id, -1)


def _locked(path: Path) -> tuple[int, bool]:
    """(descriptor of lock file path, whether this process now holds its exclusive lock)."""
    fd = os.open(path, os.O_CREAT | os.O_RDWR, 0o666)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return fd, False
    return fd, True


@contextmanager
def reserve_domain(cooldown: float = DOMAIN_COOLDOWN) -> Iterator[int]:
    """Reserve a ROS_DOMAIN_ID no other holder here has; ids released less than cooldown s
    ago come last (killed nodes linger in DDS discovery until their lease runs out)."""
    _LOCK_DIR.mkdir(parents=True, exist_ok=True)
    ids = list(DOMAIN_RANGE)
    random.SystemRandom().shuffle(ids)
    now = time.time()

    def recently_used(domain_id: int) -> bool:
        try:
            return now - (_LOCK_DIR / f'{domain_id}.lock').stat().st_mtime < cooldown
        except OSError:
            return False

    ids.sort(key=recently_used)          # rested ids first, in random order
    for domain_id in ids:
        path = _LOCK_DIR / f'{domain_id}.lock'
        fd, locked = _locked(path)
        if not locked:
            os.close(fd)
            continue
        try:
            yield domain_id
        finally:
            if domain_id in _KEPT:
                _KEPT[domain_id] = fd    # never handed out again while this process lives
            else:
                os.utime(path)           # released now: rests for `cooldown`
                fcntl.flock(fd, fcntl.LOCK_UN)
                os.close(fd)
        return
    raise RuntimeError('no free ROS domain id in %s' % DOMAIN_RANGE)


@contextmanager
def graph_lock(domain_id: int, namespace: str = '') -> Iterator[None]:
    """Hold this machine's lock on the drive graph of (domain_id, namespace); a second
    runner is refused at once (DomainBusy). Other machines: :mod:`drive_common.domain_guard`."""
    from drive_common.domain_guard import RUNNER_NODE, DomainBusy
    _LOCK_DIR.mkdir(parents=True, exist_ok=True)
    fd, locked = _locked(_LOCK_DIR / f'graph_{domain_id}{namespace.rstrip("/").replace("/", "_")}.lock')
    try:
        if not locked:
            holder = os.pread(fd, 32, 0).decode(errors='replace').strip() or 'unknown'
            where = f'ROS domain {domain_id}' + (f', namespace {namespace}' if namespace else '')
            raise DomainBusy(f'run_scenario: {where} already runs a drive graph (nodes: '
                             f'{namespace.rstrip("/")}/{RUNNER_NODE}, run_scenario pid {holder} on this '
                             'machine): refusing to start a second one (stop it, or choose another '
                             '--domain-id)') from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, str(os.getpid()).encode(), 0)
        yield
    finally:
        os.close(fd)                     # the lock goes with the descriptor


def isolated_env(domain_id: int, base: Mapping[str, str] | None = None) -> dict[str, str]:
    """Environment for a node process confined to domain_id and localhost discovery."""
    env = dict(os.environ if base is None else base)
    env['ROS_DOMAIN_ID'] = str(domain_id)
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env.pop('ROS_LOCALHOST_ONLY', None)
    env['PYTHONUNBUFFERED'] = '1'
    return env


def executable_path(package: str, executable: str) -> Path:
    """Where ``ros2 run package executable`` finds the program."""
    from ament_index_python.packages import PackageNotFoundError, get_package_prefix
    try:
        prefix = get_package_prefix(package)
    except PackageNotFoundError as exc:
        raise FileNotFoundError(
            f'no package {package!r} on AMENT_PREFIX_PATH: misspelt, or not built in the sourced '
            'workspace') from exc
    path = Path(prefix) / 'lib' / package / executable
    if not path.exists():
        raise FileNotFoundError(f'no executable {executable!r} in {path.parent}')
    return path


def _yaml_value(value: Any) -> str:
    if isinstance(value, (list, tuple)):
        return '[' + ', '.join(_yaml_value(v) for v in value) + ']'
    if isinstance(value, (bool, int, float, str)):
        return repr(value) if isinstance(value, float) else json.dumps(value)   # repr: nan, inf
    raise TypeError(f'unsupported parameter value {value!r}')


def ros_arguments(parameters: Mapping[str, Any] | None = None,
                  remappings: Mapping[str, str] | None = None,
                  node_name: str | None = None,
                  log_level: str | None = None,
                  params_files: Sequence[str] = ()) -> list[str]:
    """``--ros-args`` list as ``ros2 run`` takes it (--params-file f, -p name:=value, -r from:=to)."""
    args = ['--ros-args']
    for path in params_files:            # before -p: a -p value overrides the file's
        args += ['--params-file', str(path)]
    if node_name:
        args += ['-r', f'__node:={node_name}']
    for name, value in (parameters or {}).items():
        args += ['-p', f'{name}:={_yaml_value(value)}']
    for src, dst in (remappings or {}).items():
        args += ['-r', f'{src}:={dst}']
    if log_level:
        args += ['--log-level', log_level]
    return args


class NodeProcess:
    """A node started as ``ros2 run`` would, in its own process group; a context manager.

    Output goes to a log file (:meth:`output`); without log_dir, to a temporary folder
    that :meth:`stop` removes (the text kept).
    """

    def __init__(self, package: str, executable: str, *,
                 parameters: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None,
                 node_name: str | None = None,
                 env: Mapping[str, str] | None = None,
                 extra_args: Sequence[str] = (),
                 log_dir: str | os.PathLike | None = None,
                 argv: Sequence[str] | None = None,
                 params_files: Sequence[str] = (),
                 prefix: Sequence[str] = ()) -> None:
        """argv: run this command line instead of the installed executable
        (package and executable then only name the process in logs);
        prefix: run it through a wrapper, e.g. ``ip netns exec NAME``."""
        self.package = package
        self.executable = executable
        program = list(argv) if argv else [str(executable_path(package, executable))]
        self.command = [*prefix, *program, *extra_args,
                        *ros_arguments(parameters, remappings, node_name, params_files=params_files)]
        self._temporary_log_dir = None if log_dir else Path(tempfile.mkdtemp(prefix='dtc_node_'))
        log_dir = Path(log_dir) if log_dir else self._temporary_log_dir
        log_dir.mkdir(parents=True, exist_ok=True)
        self._final_output: str | None = None
        self.log_path = log_dir / f'{node_name or executable}.log'
        self._log = open(self.log_path, 'wb')
        self.process = subprocess.Popen(self.command, stdout=self._log, stderr=subprocess.STDOUT,
                                        env=starter_env(env), start_new_session=True)

    @property
    def pid(self) -> int:
        return self.process.pid

    def alive(self) -> bool:
        return self.process.poll() is None

    def output(self) -> str:
        if self._final_output is not None:
            return self._final_output
        if not self._log.closed:
            self._log.flush()
        return self.log_path.read_text(errors='replace')

    def _signal_group(self, sig: int) -> None:
        try:
            os.killpg(self.process.pid, sig)
        except ProcessLookupError:
            pass

    def dump_stacks(self, wait: float = 0.0) -> bool:
        """Ask a drive node for its threads' stacks (into its output), wait up to wait s
        for them; whether it was asked."""
        if self.process.poll() is not None or not catches_signal(self.process.pid, STACK_DUMP_SIGNAL):
            return False
        dumped = self.output().count(STACK_DUMP_MARK)
        os.kill(self.process.pid, STACK_DUMP_SIGNAL)
        wait_until(lambda: not self.alive() or self.output().count(STACK_DUMP_MARK) > dumped, wait,
                   0.05, raise_timeout=False)
        return True

    def stop(self, timeout: float = 5.0) -> int | None:
        """Stop the node (SIGINT, SIGTERM, SIGKILL, timeout s each; its stacks dumped before
        escalating); return its exit code."""
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL):
            if self.process.poll() is not None:
                break
            if sig != signal.SIGINT:
                self.dump_stacks()
            self._signal_group(sig)
            try:
                self.process.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                continue
        self._signal_group(signal.SIGKILL)  # leftovers of the group, if any
        try:
            self.process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            pass
        self._log.close()
        if self._temporary_log_dir is not None and self._final_output is None:
            self._final_output = self.log_path.read_text(errors='replace')
            shutil.rmtree(self._temporary_log_dir, ignore_errors=True)
        return self.process.returncode

    def __enter__(self) -> 'NodeProcess':
        return self

    def __exit__(self, *exc) -> None:
        self.stop()
