# Shared set-up for the project's scripts: sourced, not run.
# Installs missing packages, configures and builds the catkin package in $OSM_BUILD_DIR.
set -euo pipefail
OSM_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
OSM_BUILD_DIR=${OSM_BUILD_DIR:-$OSM_ROOT/build}
# pyenv's python3 first on PATH breaks catkin's and ROS's Python tools: use Debian's.
export PATH=/usr/bin:/bin:$PATH
# The shared datasets (never copied into the project).
export OSM_DATA_DIR=${OSM_DATA_DIR:-$(cd "$OSM_ROOT/.." && pwd)/shared/data}

osm_log() { printf '\033[1m[%s]\033[0m %s\n' "$(basename "$0")" "$*" >&2; }

osm_build() {
  "$OSM_ROOT/scripts/install-deps"
  osm_log "configuring and building in $OSM_BUILD_DIR"
  # shellcheck disable=SC2086  # OSM_CMAKE_ARGS holds several words on purpose
  cmake -S "$OSM_ROOT" -B "$OSM_BUILD_DIR" -DPYTHON_EXECUTABLE=/usr/bin/python3 \
    -DPython3_EXECUTABLE=/usr/bin/python3 -DCATKIN_ENABLE_TESTING=ON ${OSM_CMAKE_ARGS:-} "$@" >"$OSM_BUILD_DIR.cmake.log" 2>&1 ||
    { cat "$OSM_BUILD_DIR.cmake.log"; return 1; }
  cmake --build "$OSM_BUILD_DIR" -j"$(nproc)" -- --no-print-directory
}

osm_source() {
  # catkin's setup scripts read unset variables.
  set +u
  # shellcheck disable=SC1091
  source "$OSM_BUILD_DIR/devel/setup.bash"
  set -u
}

# The simulated session (bag + ground truth) in maps/sim, made once per build of the simulator.
osm_simulate() {
  local sim_dir="$OSM_ROOT/maps/sim"
  mkdir -p "$sim_dir"
  local tool="$OSM_BUILD_DIR/devel/lib/octo_slice_mapper/simulate_session"
  if [ ! -f "$sim_dir/office.bag" ] || [ "$tool" -nt "$sim_dir/office.bag" ]; then
    osm_log "simulating the TurtleBot session"
    "$tool" --bag "$sim_dir/office.bag" --truth "$sim_dir/truth"
  fi
}
