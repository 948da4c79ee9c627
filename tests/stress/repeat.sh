#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Runs a test command N times in a row and stops at the first failure, naming the round and
# keeping that round's output: the CTest label `stress` repeats the timing-sensitive tests with it
# (tests/stress/stress.cmake), so that a race that shows once in fifty runs shows here.
#   repeat.sh N COMMAND [ARGS...]
set -uo pipefail
n=$1
shift
log=$(mktemp)
trap 'rm -f "$log"' EXIT
start=$(date +%s)
for ((i = 1; i <= n; i++)); do
  if ! "$@" >"$log" 2>&1; then
    echo "FAILED in round $i of $n: $*" >&2
    tail -n 60 "$log" >&2
    exit 1
  fi
done
echo "$n/$n rounds passed in $(($(date +%s) - start)) s: $*"
