#!/usr/bin/env bash
# Run a scenario with plant, controller and recorder on three virtual hosts
# (network namespaces on one bridge; needs root), recorded like run_scenario:
#   sudo bash scripts/split_hosts.sh two_phase_six_switch_torque_step --duration 0.02 --out bags/split
#   sudo bash scripts/split_hosts.sh default --static-peers          # no multicast on the link
#   sudo bash scripts/split_hosts.sh default --cut-controller-at 0.01  # pull the controller's cable
# Options: ros2 run drive_bringup split_hosts --help; recipe for real machines: docs/multi_host.md
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# shellcheck disable=SC1091
source "$ROOT/scripts/env.sh"
exec python -m drive_bringup.split_hosts "$@"
