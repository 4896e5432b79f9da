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
# make_workspace DIR: the catkin workspace DIR (.ws/, or .ws_san/ for scripts/test --sanitize):
# DIR/src/drill_pipe_pose is a real folder of symlinks to the repository's top-level entries (not
# one symlink to the repository): a workspace inside the repository would otherwise be a
# file-system loop for `find -L`, which rosrun uses. Idempotent; drops links to removed entries.
make_workspace() {
  local pkg="$1/src/drill_pipe_pose" entry name link
  [[ -L "$pkg" ]] && rm -f "$pkg"  # an older layout
  mkdir -p "$pkg"
  for entry in "$REPO"/* "$REPO"/.clang-format; do
    name=$(basename "$entry")
    [[ -e "$pkg/$name" ]] || ln -s "../../../$name" "$pkg/$name"
  done
  for link in "$pkg"/*; do  # entries removed from the repository
    [[ -e "$link" ]] || rm -f "$link"
  done
}
source_ws() {
  [[ -f "$WS/devel/setup.bash" ]] || die "no workspace at $WS: run scripts/setup"
  set +u
  # shellcheck disable=SC1091
  source "$WS/devel/setup.bash"
  set -u
}

# ---- the sanitizer build (scripts/test --sanitize, scripts/fuzz) ----------------------------------
# A workspace of its own (.ws_san/, beside .ws/ which stays Release), RelWithDebInfo at -O1 -g1
# (line numbers in the reports, a third of -O2 -g's compile time), AddressSanitizer +
# UndefinedBehaviorSanitizer; float-cast-overflow too (undefined behaviour that gcc's
# -fsanitize=undefined leaves out: a NaN or 1e300 pixel coordinate converted to int). Every UB
# report is fatal (-fno-sanitize-recover), so a report fails the test that triggered it.
# -Wno-maybe-uninitialized: the sanitizers' instrumentation makes gcc 12 warn falsely in Eigen and
# <functional> (the Release build, which CI checks, keeps the warning).
SAN_WS="$REPO/.ws_san"
SAN_CXX_FLAGS="-fsanitize=address,undefined,float-cast-overflow -fno-sanitize-recover=undefined,float-cast-overflow -fno-omit-frame-pointer -Wno-maybe-uninitialized"
SAN_LD_FLAGS="-fsanitize=address,undefined,float-cast-overflow"
# Runtime options: leaks detected (third-party leaks in test/fuzz/lsan.supp, each says why); a
# report fails the process. Off, because a system library trips it, not this code:
#  - alloc_dealloc_mismatch: Debian's PCL 1.13 is built as C++14, where PointCloud has its own
#    operator new (Eigen's aligned malloc); this C++17 code has none and frees a PointCloud that
#    libpcl_io allocated (pcl::io::loadPolygonFile, mesh_io.cpp) with the plain sized delete. Both
#    end in malloc/free with glibc, so it is harmless there; ASan cannot waive it per library.
export_sanitizer_options() {
  export ASAN_OPTIONS="detect_leaks=1:abort_on_error=0:exitcode=1:alloc_dealloc_mismatch=0:strict_string_checks=1:check_initialization_order=1:max_allocation_size_mb=4096:allocator_may_return_null=0"
  export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:exitcode=1"
  export LSAN_OPTIONS="suppressions=$REPO/test/fuzz/lsan.supp:print_suppressions=0"
}
# build_sanitized LOG TARGET...: configures .ws_san (first time: creates it like .ws) and builds
# the targets with the sanitizer flags.
build_sanitized() {
  local log=$1
  shift
  make_workspace "$SAN_WS"
  # DRILL_PIPE_POSE_SANITIZE: longer test time limits (test/fuzz/fuzz.cmake).
  run_logged "$log" catkin_make -C "$SAN_WS" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG" \
    "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG" \
    "-DCMAKE_CXX_FLAGS=$SAN_CXX_FLAGS" "-DCMAKE_EXE_LINKER_FLAGS=$SAN_LD_FLAGS" \
    "-DCMAKE_SHARED_LINKER_FLAGS=$SAN_LD_FLAGS" -DDRILL_PIPE_POSE_LIBFUZZER=OFF \
    -DDRILL_PIPE_POSE_SANITIZE=ON -j"$JOBS" "$@"
}
