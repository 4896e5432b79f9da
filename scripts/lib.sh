# Shared helpers for scripts/*: stage timing, messages, workspace paths. Source, do not run.
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
WS="$REPO/.ws"
JOBS=${JOBS:-$(nproc)}
export ROS_HOME="$WS/ros_home"
export ROS_LOG_DIR="$ROS_HOME/log"

_stage_name=""
_stage_t0=0
say() { echo "[drill_pipe_pose] $*"; }
die() { echo "[drill_pipe_pose] ERROR: $*" >&2; exit 1; }
end_stage() {
  if [[ -n "$_stage_name" ]]; then
    say "stage '$_stage_name' took $(($(date +%s) - _stage_t0)) s"
  fi
  _stage_name=""
}
stage() {
  end_stage
  _stage_name="$1"
  _stage_t0=$(date +%s)
  say "== $1"
}
# run_logged LOG CMD...: runs CMD with its output in LOG; prints the warnings and the last lines
# on success, the whole log on failure (and exits).
run_logged() {
  local log=$1
  shift
  mkdir -p "$(dirname "$log")"
  if ! "$@" >"$log" 2>&1; then
    cat "$log"
    die "failed: $* (log: $log)"
  fi
  grep -E "warning:" "$log" | head -20 || true
  tail -n 2 "$log"
}
source_ws() {
  [[ -f "$WS/devel/setup.bash" ]] || die "no workspace at $WS: run scripts/setup"
  set +u
  # shellcheck disable=SC1091
  source "$WS/devel/setup.bash"
  set -u
}
