"""split_hosts: run a scenario with the plant and its controllers on different hosts.

    split_hosts two_phase_six_switch_torque_step --duration 0.012 --out bags/split
    split_hosts two_phase_six_switch_torque_step --cut-controller-at 0.005 --out bags/cut

Three virtual hosts (Linux network namespaces, ``drive_common.netns``; needs root) on one
bridged link: ``plant``, ``controller`` (the controllers) and ``supervisor`` (recorder, runner).
``--cut-controller-at T`` takes the controller host's link down at sim time T: the plant must
go to the safe state with a diagnostic (exit 1), not hang. Exit codes as run_scenario (2 also
without virtual hosts). Discovery and real machines: docs/multi_host.md.
"""
from __future__ import annotations

import argparse
import os
import sys
from contextlib import nullcontext
from pathlib import Path

from drive_bringup.runner import GraphRunner
from drive_common import topics
from drive_common.netns import VirtualHosts

HOSTS = ('plant', 'controller', 'supervisor')
PLACEMENT = {'plant': 'plant', 'dtc_controller': 'controller', 'controller': 'controller',
             'pfc_controller': 'controller', 'recorder': 'supervisor'}
RUNNER_HOST = 'supervisor'


class SplitHostRunner(GraphRunner):
    """GraphRunner whose nodes run in the virtual hosts of ``PLACEMENT``.

    Construct it after ``hosts.enter(RUNNER_HOST)`` so this process's own
    ROS client talks from the supervisor host.
    """

    def __init__(self, scenario, out_dir, *, hosts: VirtualHosts, domain_id: int,
                 static_peers: bool = False, cut_controller_at: float | None = None,
                 **kwargs) -> None:
        super().__init__(scenario, out_dir, domain_id=domain_id, **kwargs)
        self.hosts = hosts
        self.static_peers = static_peers
        self.cut_controller_at = cut_controller_at

    def _placement(self, key: str) -> dict:
        host = PLACEMENT.get(key, RUNNER_HOST)     # helpers (e.g. a live view) beside the runner
        return {'env': self.hosts.env(host, self.domain_id, static_peers=self.static_peers),
                'prefix': self.hosts.prefix(host)}

    def _wait_ready(self, node, executor, action) -> None:
        if self.record:
            from dtc_msgs.msg import PlantStateBlock
            self._state_end = self._follow_blocks(node, PlantStateBlock, topics.PLANT_STATE_BLOCK)
        super()._wait_ready(node, executor, action)

    def _drive(self, node, executor, bag_dir):
        result = super()._drive(node, executor, bag_dir)
        if self.record:
            self._wait_delivered(executor, result.final_step)
        return result

    def _wait_delivered(self, executor, final_step: int) -> None:
        """Wait until this (supervisor) host has the plant's last ground-truth sample.

        The Run result can overtake the last samples on their way across the
        link; the recorder's copies crossed it with this runner's, so once
        the runner has the last one the recorder's stop-time drain takes the
        rest instead of stopping short of the end.
        """
        ticks = self._schedule().state_ticks
        last = final_step - final_step % ticks
        if not self._spin_while_waiting(executor, lambda: self._state_end[0] >= last, 30.0, 'the last sample',
                                        raise_timeout=False):
            self.progress(f'warning: plant/state_block step {last} did not reach the supervisor '
                          f'host within 30 s (last seen {self._state_end[0]})')

    def _run_goal(self, executor, target: float, started: float) -> tuple[int, float]:
        cut = self.cut_controller_at
        if cut is not None and target > cut:
            self.cut_controller_at = None
            if cut > 0:
                super()._run_goal(executor, cut, started)
            self.hosts.cut('controller')
            self.progress(f'[{self.scenario.name}] t = {cut:.6f} s: controller host link down')
        return super()._run_goal(executor, target, started)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog='split_hosts', description=__doc__.split('\n')[0])
    parser.add_argument('scenario', help='scenario name (run_scenario --list) or YAML path')
    parser.add_argument('--duration', type=float, help='override the run length (s)')
    parser.add_argument('--out', type=Path, help='output directory (default bags/<name>)')
    parser.add_argument('--overwrite', action='store_true', help='replace an existing --out')
    parser.add_argument('--no-record', action='store_true', help='do not record a bag')
    parser.add_argument('--static-peers', action='store_true',
                        help='unicast discovery on a link without multicast: '
                             'ROS_STATIC_PEERS = the other hosts')
    parser.add_argument('--cut-controller-at', type=float, metavar='T',
                        help='take the controller host link down at sim time T (s)')
    parser.add_argument('--domain', type=int,
                        help='ROS_DOMAIN_ID (default: a free one, reserved on this machine)')
    return parser


def main(argv=None) -> int:
    from drive_bringup.runner import main_guard
    from drive_bringup.runner_cli import prepare_run, print_summary
    from drive_bringup.scenario import ScenarioError
    from drive_common.netns import unavailable_reason
    args = build_parser().parse_args(argv)
    reason = unavailable_reason()
    if reason:
        print(f'split_hosts: cannot make virtual hosts: {reason}', file=sys.stderr)
        return 2
    def check_cut(scenario) -> None:
        if args.cut_controller_at is not None and not 0 <= args.cut_controller_at < scenario.duration:
            raise ScenarioError(f'--cut-controller-at {args.cut_controller_at} is outside '
                                f'[0, {scenario.duration}) s of {scenario.name}')

    try:
        scenario, out = prepare_run(args, check=check_cut)
    except ScenarioError as exc:
        print(f'error: {exc}', file=sys.stderr)
        return 2

    def run_in(domain: int) -> int:
        with VirtualHosts(HOSTS, multicast=not args.static_peers) as hosts:
            hosts.enter(RUNNER_HOST)
            # This process's own ROS client discovers like the nodes in its host.
            env = hosts.env(RUNNER_HOST, domain, static_peers=args.static_peers)
            os.environ.clear()
            os.environ.update(env)
            for label in HOSTS:
                print(f'host {label}: {hosts.addresses[label]} (netns {hosts.namespaces[label]})')
            runner = SplitHostRunner(scenario, out, hosts=hosts, domain_id=domain,
                                     static_peers=args.static_peers,
                                     cut_controller_at=args.cut_controller_at,
                                     record=not args.no_record)
            result = runner.run()
        if result.bag is not None:
            from drive_bringup.report import write_report
            print_summary(write_report(scenario, result, out), out)
        return 0

    def run() -> int:
        from drive_common.processes import reserve_domain
        with nullcontext(args.domain) if args.domain is not None else reserve_domain() as domain:
            return run_in(domain)

    return main_guard(run)


if __name__ == '__main__':
    raise SystemExit(main())
