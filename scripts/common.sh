# Shared by scripts/setup, scripts/demo and scripts/test: paths and a clean environment.
# Sourced, not run.

# A pyenv (or other) python3 earlier on PATH breaks catkin: Debian's ROS lives in /usr.
export PATH="/usr/bin:/bin:/usr/sbin:/sbin:${PATH}"
# Resolve links: the scripts may be reached through the workspace's link to this folder.
BSF_REPO="$(cd "$(dirname "$(readlink -f "${BASH_SOURCE[0]}")")/.." && pwd)"
BSF_WS="${BSF_REPO}/build/ws"
export BSF_REPO BSF_WS

# Makes rosrun/roslaunch find the package built under build/ws.
bsf_source_workspace() {
  # setup.bash reads unset variables; relax nounset while it runs.
  set +u
  # shellcheck disable=SC1091
  source "${BSF_WS}/devel/setup.bash"
  set -u
}
