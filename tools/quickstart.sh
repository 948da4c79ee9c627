#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# The README's quick start. On a fresh Debian 12 machine (as root, or with sudo):
#   bash tools/quickstart.sh run    install what is missing, build (Release), run the main job
#   bash tools/quickstart.sh test   install what is missing, build (Release), run the whole test suite
#   bash tools/quickstart.sh sanitize   the same, built with AddressSanitizer + UBSan (Debug, in
#                                   build-asan): the whole suite under the sanitizers
# Environment: BUILD_DIR (default build, build-asan for sanitize), JOBS (default nproc), CMAKE_ARGS
# (extra configure flags).
set -euo pipefail

mode="${1:-}"
case "$mode" in
  run|test|sanitize) ;;
  *) echo "usage: $0 run|test|sanitize" >&2; exit 2 ;;
esac

cd "$(dirname "$0")/.."
BUILD_TYPE=Release
MODE_ARGS=""
if [ "$mode" = sanitize ]; then
  BUILD_DIR="${BUILD_DIR:-build-asan}"
  BUILD_TYPE=Debug
  # Benchmarks measure nothing under the sanitizers; leave them out of this build.
  MODE_ARGS="-DADIT_SANITIZE=ON -DADIT_BUILD_BENCHMARKS=OFF"
fi
BUILD_DIR="${BUILD_DIR:-build}"
JOBS="${JOBS:-$(nproc)}"

# Debian 12 packages adit builds against. OMPL's CMake config also needs its boost and ODE
# companions (the global planner).
PKGS=(cmake g++ make pkg-config
      liboctomap-dev libfcl-dev libccd-dev libeigen3-dev
      libyaml-cpp-dev libcli11-dev nlohmann-json3-dev libcairo2-dev
      libompl-dev libboost-serialization-dev libboost-filesystem-dev libboost-system-dev libode-dev
      libboost1.74-dev
      libgtest-dev libgmock-dev libbenchmark-dev
      libopen3d-dev libassimp-dev libdxflib-dev libpugixml-dev
      libsqlite3-dev libpqxx-dev libjs-three libssl-dev doxygen)
# What only the test suite needs: headless Chromium for the pages' browser tests; slurm-wlm and
# munge for the campaign test's throw-away one-node Slurm cluster (tests/tools/campaign_slurm.sh
# starts its own daemons, never the system's); PostgreSQL's server for the console store's
# throw-away database (started by the test in a temp dir, never the system's cluster); python3 for
# the test scripts that read JSON and drive the console over HTTP.
TEST_PKGS=(chromium slurm-wlm munge postgresql python3 python3-jsonschema)
if [ "$mode" != run ]; then PKGS+=("${TEST_PKGS[@]}"); fi

missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "== installing: ${missing[*]}" >&2
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -q
  # Installing munge, slurm-wlm and postgresql must not start their daemons (a fresh container has
  # no init to run them; a host needs none of them): a policy-rc.d that denies every start, for the install
  # only, unless one is there already (Debian's container images ship one).
  policy=/usr/sbin/policy-rc.d
  added_policy=""
  if [ ! -e "$policy" ]; then
    printf '#!/bin/sh\n# tools/quickstart.sh: no daemon starts while it installs packages\nexit 101\n' | $SUDO tee "$policy" >/dev/null
    $SUDO chmod 755 "$policy"
    added_policy=1
  fi
  install_rc=0
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}" || install_rc=$?
  if [ -n "$added_policy" ]; then $SUDO rm -f "$policy"; fi
  [ "$install_rc" -eq 0 ] || exit "$install_rc"
fi

echo "== configuring and building ($BUILD_DIR, $BUILD_TYPE, $JOBS jobs)" >&2
# shellcheck disable=SC2086
cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=$BUILD_TYPE $MODE_ARGS ${CMAKE_ARGS:-} >/dev/null
cmake --build "$BUILD_DIR" -j "$JOBS"

if [ "$mode" = run ]; then
  mkdir -p out
  echo "== adit map info maps/district.yaml" >&2
  "$BUILD_DIR/bin/adit" map info maps/district.yaml
  echo "== adit map slice maps/district.yaml --out out/district_top.png" >&2
  "$BUILD_DIR/bin/adit" map slice maps/district.yaml --out out/district_top.png
  echo "== adit plan --map maps/district.yaml --farthest-ends --out out/district_plan.json --picture out/district_plan.png" >&2
  "$BUILD_DIR/bin/adit" plan --map maps/district.yaml --farthest-ends --out out/district_plan.json \
      --picture out/district_plan.png
  echo "== adit simulate maps/scenarios/district_rescue.yaml --out out/rescue.json --picture out/rescue.png --html out/rescue.html" >&2
  "$BUILD_DIR/bin/adit" simulate maps/scenarios/district_rescue.yaml --out out/rescue.json \
      --picture out/rescue.png --html out/rescue.html
  echo "== done: the top view is out/district_top.png, the planned path out/district_plan.png," \
       "the rescue run out/rescue.png and out/rescue.html" >&2
else
  # The label `stress` repeats the timing-sensitive tests for many rounds (tests/stress/): run it
  # on purpose, `ctest --test-dir build -L stress`.
  ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$JOBS" -LE stress
fi
