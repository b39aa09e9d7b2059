"""Virtual hosts on one machine: Linux network namespaces joined by a bridge (docs/multi_host.md).

Each host has loopback, one ``eth0`` (veth to a bridge in a "switch" namespace) at
``10.213.0.<n>/24`` and a multicast route, so DDS sees machines on one LAN. Namespaces left
by a SIGKILLed run (its pid is in the name) are removed. Needs root and iproute2's ``ip``.
"""
from __future__ import annotations

import ctypes
import os
import secrets
import shutil
import signal
import subprocess
from pathlib import Path
from typing import Mapping, Sequence

from drive_common.processes import isolated_env

PREFIX = 'dtcvh'          # every namespace made here starts with this
SUBNET = '10.213.0'       # /24 inside the bridge; only ever routed inside our namespaces
_NETNS_DIR = Path('/run/netns')
_CLONE_NEWNET = 0x40000000
# Fast DDS profile across hosts: larger receive buffers, 20 ms heartbeat (see the file).
FASTDDS_PROFILE = Path(__file__).with_name('fastdds_network.xml')


class HostsUnavailable(RuntimeError):
    """Network namespaces cannot be made here (not root, or no ``ip``)."""


def unavailable_reason() -> str | None:
    """Why virtual hosts cannot be created on this machine, or None when they can."""
    if os.geteuid() != 0:
        return 'network namespaces need root (CAP_SYS_ADMIN/CAP_NET_ADMIN); CI runs as root'
    if shutil.which('ip') is None:
        return "iproute2's `ip` is not installed (apt-get install iproute2)"
    return None


def _ip(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    result = subprocess.run(['ip', *args], capture_output=True, text=True)
    if check and result.returncode != 0:
        raise RuntimeError(f'ip {" ".join(args)}: {result.stderr.strip()}')
    return result


def _delete(namespace: str) -> None:
    """SIGKILL every process still running in namespace (but this one, see enter()); delete it."""
    pids = {int(p) for p in _ip('netns', 'pids', namespace, check=False).stdout.split()}
    for pid in pids - {os.getpid()}:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    _ip('netns', 'delete', namespace, check=False)


def remove_stale() -> list[str]:
    """Delete namespaces of this module whose creating process is gone; their names."""
    removed = []
    names = _ip('netns', 'list', check=False).stdout.split('\n')
    for line in names:
        name = line.split(' ')[0]
        parts = name.split('-')
        if len(parts) >= 3 and parts[0] == PREFIX and parts[1].isdigit() \
                and not os.path.exists(f'/proc/{parts[1]}'):       # its creator is gone
            _delete(name)
            removed.append(name)
    return removed


class VirtualHosts:
    """Named hosts (short labels; host i at ``10.213.0.<i+1>``) on one bridged link; a context
    manager. multicast False: no multicast route (only static peers discover)."""

    def __init__(self, hosts: Sequence[str] = ('a', 'b'), multicast: bool = True) -> None:
        if len(set(hosts)) != len(hosts) or not hosts or len(hosts) > 250:
            raise ValueError(f'host labels must be 1..250 distinct names, got {list(hosts)}')
        self.labels = list(hosts)
        self.multicast = multicast
        self.run_id = f'{PREFIX}-{os.getpid()}-{secrets.token_hex(3)}'
        self.namespaces = {label: f'{self.run_id}-h{i}' for i, label in enumerate(self.labels)}
        self.switch = f'{self.run_id}-sw'
        self.addresses = {label: f'{SUBNET}.{i + 1}' for i, label in enumerate(self.labels)}
        self._made: list[str] = []

    def create(self) -> 'VirtualHosts':
        reason = unavailable_reason()
        if reason:
            raise HostsUnavailable(reason)
        remove_stale()
        try:
            for ns in (self.switch, *self.namespaces.values()):
                _ip('netns', 'add', ns)
                self._made.append(ns)
            _ip('-n', self.switch, 'link', 'add', 'br0', 'type', 'bridge', 'mcast_snooping', '0')
            _ip('-n', self.switch, 'link', 'set', 'br0', 'up')
            for i, label in enumerate(self.labels):
                ns = self.namespaces[label]
                port = f'p{i}'
                _ip('link', 'add', 'eth0', 'netns', ns, 'type', 'veth',
                    'peer', 'name', port, 'netns', self.switch)
                _ip('-n', self.switch, 'link', 'set', port, 'master', 'br0', 'up')
                _ip('-n', ns, 'link', 'set', 'lo', 'up')
                _ip('-n', ns, 'addr', 'add', f'{self.addresses[label]}/24', 'dev', 'eth0')
                _ip('-n', ns, 'link', 'set', 'eth0', 'up')
                if self.multicast:   # SPDP discovery goes to 239.255.0.1, and there is no default route
                    _ip('-n', ns, 'route', 'replace', '224.0.0.0/4', 'dev', 'eth0')
        except BaseException:
            self.close()
            raise
        return self

    def close(self) -> None:
        """Kill what still runs in the hosts and delete every namespace made."""
        for name in reversed(self._made):
            _delete(name)
        self._made.clear()

    def __enter__(self) -> 'VirtualHosts':
        return self.create()

    def __exit__(self, *exc) -> None:
        self.close()

    def prefix(self, host: str) -> list[str]:
        """Command prefix running a program in host (as root: ``ip netns exec NAME``)."""
        return ['ip', 'netns', 'exec', self.namespaces[host]]

    def env(self, host: str, domain_id: int, base: Mapping[str, str] | None = None,
            static_peers: bool = False) -> dict[str, str]:
        """ROS environment for a node in host: the shared domain, :data:`FASTDDS_PROFILE` (unless
        set), discovery range SUBNET, or with static_peers LOCALHOST plus the others as peers."""
        env = isolated_env(domain_id, base)
        if static_peers:
            env['ROS_STATIC_PEERS'] = ';'.join(a for h, a in self.addresses.items() if h != host)
        else:
            env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'SUBNET'
            env.pop('ROS_STATIC_PEERS', None)
        env.setdefault('FASTRTPS_DEFAULT_PROFILES_FILE', str(FASTDDS_PROFILE))
        return env

    def exec(self, host: str, command: Sequence[str], **kwargs) -> subprocess.CompletedProcess:
        """Run command in host to completion (subprocess.run keyword arguments)."""
        return subprocess.run([*self.prefix(host), *command], **kwargs)

    def enter(self, host: str) -> None:
        """Move this process into host's network namespace (setns(2)), before any thread starts."""
        libc = ctypes.CDLL(None, use_errno=True)
        fd = os.open(_NETNS_DIR / self.namespaces[host], os.O_RDONLY)
        try:
            if libc.setns(fd, _CLONE_NEWNET) != 0:
                errno = ctypes.get_errno()
                raise OSError(errno, f'setns into {self.namespaces[host]}: {os.strerror(errno)}')
        finally:
            os.close(fd)

    def cut(self, host: str) -> None:
        """Pull host's cable: its eth0 goes down (loopback stays up)."""
        _ip('-n', self.namespaces[host], 'link', 'set', 'eth0', 'down')
