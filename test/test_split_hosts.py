"""The node graph split across hosts: hardware-in-the-loop on one machine.

The plant, the dtc_controller and the recorder (with the runner's client)
run in three network namespaces joined by a bridge (drive_common.netns) —
three hosts as far as DDS can tell, every lockstep message crosses the link
as UDP. Checked:

- the split run records the same message data, byte for byte, as the
  single-host run of the same scenario (the lockstep is deterministic);
- pulling the controller host's cable (``ip link set eth0 down``) between
  two goals (at an exact sim time) or from outside while a goal runs puts
  the plant in the safe state with a diagnostic, and the run ends with the
  plant's reason instead of hanging;
- the virtual hosts are removed after use, after an exception, and after a
  creator that was SIGKILLed.

Needs root for network namespaces (CI runs as root); skipped otherwise,
with that reason. As root without iproute2's ``ip`` the tests fail.
"""
import os
import re
import subprocess
import sys
import textwrap

import pytest

from drive_common.netns import PREFIX, VirtualHosts, remove_stale, unavailable_reason
from drive_common.telemetry_blocks import expand
from drive_logger.bag_reader import BagReader

pytestmark = [pytest.mark.ros,
              pytest.mark.skipif(os.geteuid() != 0,
                                 reason='network namespaces need root (CI runs as root)')]

SCENARIO = 'two_phase_six_switch_torque_step'
DURATION = 0.012          # s: covers the torque step at 9.4 ms
CUT_AT = 0.004            # s: the controller host's link goes down here
RECORDED_TOPICS = ('/dtc/status_block', '/plant/state_block')   # every sample, in blocks


def run_module(module, *args, timeout=300):
    return subprocess.run([sys.executable, '-m', module, *args],
                          capture_output=True, text=True, timeout=timeout)


def _samples(reader, topic: str) -> list[tuple]:
    """The per-sample messages of a bag's block topic, in order."""
    from rclpy.serialization import deserialize_message

    from drive_logger.ros_types import message_class
    block_type = message_class(reader.topics[topic].type)
    return [record for m in reader.messages([topic])
            for record in expand(deserialize_message(m.data, block_type))]


def _plant_states(reader) -> list:
    """Every plant/state sample of a bag, from its plant/state_block messages."""
    return [state for (state,) in _samples(reader, '/plant/state_block')]


def bag_data(bag_dir) -> dict[str, list[bytes]]:
    out: dict[str, list[bytes]] = {}
    for msg in BagReader(bag_dir).messages():
        out.setdefault(msg.topic, []).append(msg.data)
    return out


def our_namespaces() -> list[str]:
    listing = subprocess.run(['ip', 'netns', 'list'], capture_output=True, text=True).stdout
    return [line.split(' ')[0] for line in listing.splitlines() if line.startswith(PREFIX + '-')]


def test_namespaces_can_be_made_here():
    """As root the hosts must be possible: a missing `ip` fails here, not skips."""
    assert unavailable_reason() is None


@pytest.fixture(scope='module')
def single_host_run(tmp_path_factory):
    out = tmp_path_factory.mktemp('single') / 'out'
    result = run_module('drive_bringup.runner_cli', SCENARIO, '--duration', str(DURATION),
                        '--isolate', '--out', str(out))
    assert result.returncode == 0, result.stdout + result.stderr
    return out


@pytest.fixture(scope='module', params=['multicast', 'static_peers'])
def split_run(request, tmp_path_factory):
    """Discovery by SUBNET multicast, or by ROS_STATIC_PEERS on a link without multicast."""
    out = tmp_path_factory.mktemp(request.param) / 'out'
    options = ['--static-peers'] if request.param == 'static_peers' else []
    result = run_module('drive_bringup.split_hosts', SCENARIO, '--duration', str(DURATION),
                        *options, '--out', str(out))
    assert result.returncode == 0, result.stdout + result.stderr
    return out, result


def test_split_run_records_the_single_host_message_data(split_run, single_host_run):
    out, result = split_run
    assert 'host plant: 10.213.0.1' in result.stdout
    assert 'host controller: 10.213.0.2' in result.stdout
    split, single = bag_data(out / 'bag'), bag_data(single_host_run / 'bag')
    samples = round(DURATION * 30000)
    commands = [m.step for m, _, _ in _samples(BagReader(out / 'bag'), '/dtc/status_block')]
    assert commands == list(range(samples))
    for topic in RECORDED_TOPICS:
        assert split[topic] == single[topic], f'{topic} differs between split and single host'


def test_link_cut_puts_the_plant_in_the_safe_state(tmp_path):
    out = tmp_path / 'cut'
    result = run_module('drive_bringup.split_hosts', SCENARIO, '--duration', str(DURATION),
                        '--cut-controller-at', str(CUT_AT), '--out', str(out))
    assert result.returncode == 1, result.stdout + result.stderr
    assert 'controller host link down' in result.stdout
    assert 'safe state' in result.stderr and 'no gate command for step' in result.stderr, \
        result.stderr
    reader = BagReader(out / 'bag')
    errors = [m.status[0].message for _, m in reader.decoded_messages(['/diagnostics'])
              if m.status[0].level in (2, b'\x02')]
    assert any(re.match(r'(command_timeout|lost_controller): no gate command', e) for e in errors), errors
    states = _plant_states(reader)
    cut_step = round(CUT_AT * 30000)
    before = [s for s in states if s.step <= cut_step]
    after = [s for s in states if s.step > cut_step + 1]
    assert before and not any(s.safe_state for s in before)
    # The plant ran on to its goal's target with the switches off (not hung at the cut).
    assert after and f'(step {after[-1].step}) with faults' in result.stderr
    assert all(s.safe_state and not any(s.applied_switch_on) for s in after)
    assert all(s.protection & 8 for s in after)       # PROTECTION_COMMAND_TIMEOUT


def test_cable_pulled_during_a_run_goal_puts_the_plant_in_the_safe_state(tmp_path):
    """The controller host's eth0 goes down from outside while the plant is stepping."""
    out = tmp_path / 'pulled'
    # A scenario long enough to shorten to several seconds of wall time with no event before its
    # end (--duration only shortens), so the cut lands mid-goal; T_s = 25 us.
    scenario, duration, rate = 'two_phase_six_switch_flux_control', 0.25, 40000
    process = subprocess.Popen([sys.executable, '-u', '-m', 'drive_bringup.split_hosts', scenario,
                                '--duration', str(duration), '--out', str(out)],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        for line in process.stdout:          # progress lines come while a goal runs
            if '] sim ' in line:
                break
        controller = [n for n in our_namespaces() if n.startswith(f'{PREFIX}-{process.pid}-')
                      and n.endswith('-h1')]
        assert len(controller) == 1, our_namespaces()
        subprocess.run(['ip', '-n', controller[0], 'link', 'set', 'eth0', 'down'], check=True)
        rest, stderr = process.communicate(timeout=300)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == 1, rest + stderr
    fault = re.search(r'safe state at t = ([0-9.]+) s: no gate command for step (\d+)', stderr)
    assert fault, stderr
    assert 0.0 < float(fault.group(1)) < duration
    steps = [m.step for m in _plant_states(BagReader(out / 'bag')) if m.safe_state]
    assert steps and steps[0] == int(fault.group(2)) + 1 and steps[-1] == round(duration * rate)


def test_hosts_are_removed_after_an_exception():
    with pytest.raises(RuntimeError, match='boom'):
        with VirtualHosts(('a', 'b')) as hosts:
            names = [*hosts.namespaces.values(), hosts.switch]
            assert set(names) <= set(our_namespaces())
            # The link carries traffic between the two hosts only.
            ping = hosts.exec('a', [sys.executable, '-c', textwrap.dedent(f'''
                import socket
                s = socket.create_connection(('{hosts.addresses['b']}', 9), timeout=5)
                ''')], capture_output=True, text=True)
            assert 'refused' in ping.stderr      # b answered (RST): reachable over the link
            raise RuntimeError('boom')
    assert not set(names) & set(our_namespaces())


MULTICAST_SEND = textwrap.dedent('''
    import socket
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        s.sendto(b'x', ('239.255.0.1', 7400))
        print('sent')
    except OSError as exc:
        print(exc.strerror)
    ''')


@pytest.mark.parametrize('multicast', [True, False])
def test_multicast_reaches_the_link_only_when_enabled(multicast):
    """The static-peers run's link carries no multicast (so its discovery is unicast)."""
    with VirtualHosts(('a', 'b'), multicast=multicast) as hosts:
        result = hosts.exec('a', [sys.executable, '-c', MULTICAST_SEND],
                            capture_output=True, text=True)
    assert result.stdout.strip() == ('sent' if multicast else 'Network is unreachable'), result


def test_hosts_of_a_killed_creator_are_removed():
    child = subprocess.Popen([sys.executable, '-c', textwrap.dedent('''
        import sys, time
        from drive_common.netns import VirtualHosts
        hosts = VirtualHosts(('a', 'b')).create()
        print(hosts.run_id, flush=True)
        time.sleep(600)
        ''')], stdout=subprocess.PIPE, text=True)
    run_id = child.stdout.readline().strip()
    child.kill()
    child.wait()
    assert run_id and any(n.startswith(run_id) for n in our_namespaces())
    removed = remove_stale()
    assert any(n.startswith(run_id) for n in removed)
    assert not any(n.startswith(run_id) for n in our_namespaces())
