#!/usr/bin/env bash
# The main job, from a fresh clone: set up, then run the default scenario
# (six-switch two-phase DTC of the dissertation's BLDC motor with a torque
# step) through the ROS graph -- plant, dtc_controller and recorder as
# separate processes -- recorded to bags/<scenario>/ with report.json and
# figures/, ending with a short summary.
#   bash scripts/main.sh [run_scenario args]    (default: the default scenario)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
bash scripts/setup.sh
# shellcheck disable=SC1091
source scripts/env.sh
if [ "$#" -eq 0 ]; then
  set -- two_phase_six_switch_torque_step --overwrite
fi
exec python -m drive_bringup.runner_cli "$@"
