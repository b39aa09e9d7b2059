# Source me: puts the workspace's Python, ROS and built packages on this shell.
#   source scripts/env.sh
# (run `bash scripts/setup.sh` once first). --no-workspace skips install/.
_DTC_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# shellcheck disable=SC1091
source "$_DTC_ROOT/.venv/bin/activate"
if [ -z "${ROS_DISTRO:-}" ] || [ ! -d "/opt/ros/${ROS_DISTRO:-none}" ]; then
  # Embedded ROS from the wheels: the venv prefix is the ament prefix.
  export AMENT_PREFIX_PATH="$VIRTUAL_ENV${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
  export CMAKE_PREFIX_PATH="$VIRTUAL_ENV${CMAKE_PREFIX_PATH:+:$CMAKE_PREFIX_PATH}"
  export ROS_DISTRO=jazzy
fi
export RMW_IMPLEMENTATION="${RMW_IMPLEMENTATION:-rmw_fastrtps_cpp}"
# The drive graph's Fast DDS profile (src/drive_common/drive_common/fastdds_network.xml): 20 ms
# heartbeats, so a reliable sample lost in a burst is repaired in milliseconds rather than 3 s
# (before a recorder being stopped finalizes its bag), and 4 MiB socket buffers.
export FASTRTPS_DEFAULT_PROFILES_FILE="${FASTRTPS_DEFAULT_PROFILES_FILE:-$_DTC_ROOT/src/drive_common/drive_common/fastdds_network.xml}"
if [ "${1:-}" != "--no-workspace" ] && [ -f "$_DTC_ROOT/install/local_setup.bash" ]; then
  # colcon's scripts read unset variables: relax `set -u` while sourcing them.
  _dtc_nounset=$(set +o | grep nounset)
  set +u
  # shellcheck disable=SC1091
  source "$_DTC_ROOT/install/local_setup.bash"
  eval "$_dtc_nounset"
  unset _dtc_nounset
fi
# Compiled kernels (drive_common.compiled, numba) cache their machine code in the workspace.
export NUMBA_CACHE_DIR="${NUMBA_CACHE_DIR:-$_DTC_ROOT/.numba_cache}"
unset _DTC_ROOT
