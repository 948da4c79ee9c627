#!/bin/sh
# SPDX-License-Identifier: BSD-3-Clause
# The console's load figures (issue 11; by hand, never by CTest): starts `adit serve` on a free
# loopback port with the given database, runs adit_console_load (10 robots at 50 Hz for 30 s and
# one viewer; tests/console/load_client.cpp) against it, prints its JSON, stops the server.
#
#   tests/console/integration_load.sh BUILD_DIR DB [LOAD_ARGS...]
#     DB: sqlite:PATH, 'sqlite:PATH?synchronous=normal' or postgresql://...
#   e.g. tests/console/integration_load.sh build sqlite:/tmp/load.db --seconds 30
set -eu
build=${1:?usage: integration_load.sh BUILD_DIR DB [LOAD_ARGS...]}
db=${2:?usage: integration_load.sh BUILD_DIR DB [LOAD_ARGS...]}
shift 2
root=$(cd "$(dirname "$0")/../.." && pwd)
log=$(mktemp)
# ADIT_SERVE_ARGS: more `adit serve` options (e.g. "--robot-bandwidth 256k").
# shellcheck disable=SC2086
"$build/bin/adit" serve --map "$root/maps/district.yaml" --db "$db" --listen 127.0.0.1:0 --quiet ${ADIT_SERVE_ARGS:-} 2>"$log" &
pid=$!
trap 'kill "$pid" 2>/dev/null || true; wait "$pid" 2>/dev/null || true; rm -f "$log"' EXIT INT TERM
i=0
until grep -q 'adit serve: http://' "$log"; do
  if ! kill -0 "$pid" 2>/dev/null || [ $i -ge 600 ]; then cat "$log" >&2; exit 1; fi
  sleep 0.1; i=$((i + 1))
done
url=$(sed -n 's|^adit serve: http://\([^/]*\)/.*|ws://\1|p' "$log")
token=$(sed -n 's|^adit serve: operator token ([^)]*): \(.*\)$|\1|p' "$log")
"$build/tests/adit_console_load" --url "$url" --map "$root/maps/district.yaml" --server-pid "$pid" --token "$token" "$@"
