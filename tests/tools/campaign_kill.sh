#!/bin/bash
# SPDX-License-Identifier: BSD-3-Clause
# A killed shard is re-run alone (issue 9). Shard 0 of 2 is killed with SIGKILL while its
# workers are mid-run; then: no file of shard 0 exists (shard files are written atomically at
# the end), no worker outlives it (they die with their parent), the other shard's file is
# untouched, and after shard 0 alone is run again the merge equals the one-process run: the
# same rows (sorted by index, without the two wall-clock step-time columns) and counts.
# Usage: campaign_kill.sh ADIT MAP N SEED
set -euo pipefail
ADIT=$1 MAP=$2 N=$3 SEED=$4
SLOWDOWN=${ADIT_TEST_SLOWDOWN:-1}  # 10 in sanitizer and Debug builds: the map loads slower

T=$(mktemp -d /tmp/adit-kill-test.XXXXXX)
trap 'rm -rf "$T"' EXIT
run() { "$ADIT" campaign run -q --map "$MAP" --scenarios "$N" --seed "$SEED" "$@"; }
rows() { tail -n +2 "$1" | cut -d, -f1-7,10- | sort -t, -k1,1n; }
counts() { python3 -c 'import json,sys; print(json.dumps(json.load(open(sys.argv[1]))["stats"]["counts"], sort_keys=True))' "$1"; }

run --jobs 2 --out "$T/one"
run --shard 1/2 --jobs 1 --out "$T/sharded"
before=$(sha256sum "$T"/sharded/shard-1-of-2.*)

# Shard 0, killed once its workers are running scenarios (adit itself in the background, not a
# subshell running it).
"$ADIT" campaign run -q --map "$MAP" --scenarios "$N" --seed "$SEED" --shard 0/2 --jobs 2 --out "$T/sharded" &
pid=$!
for _ in $(seq $((600 * SLOWDOWN))); do
  [ -n "$(pgrep -P "$pid" || true)" ] && break
  sleep 0.05
done
# Frozen first, so that it can neither finish nor start more workers however late this script
# runs on a loaded machine; its workers go on computing until it is killed.
kill -STOP "$pid"
workers=$(pgrep -P "$pid" | tr '\n' ' ' || true)
[ -n "$workers" ] || { echo "shard 0 started no workers" >&2; exit 1; }
kill -KILL "$pid"
wait "$pid" 2>/dev/null && { echo "shard 0 finished before it was killed: make N larger" >&2; exit 1; }
for _ in $(seq 20); do  # 1 s: a worker dies with its parent, not after its current run
  alive=""
  # A dead worker may stay a zombie when no init reaps orphans (containers): not alive.
  for w in $workers; do
    state=$(ps -o stat= -p "$w" 2>/dev/null | tr -d " " || true)
    [ -n "$state" ] && [ "${state:0:1}" != Z ] && alive="$alive $w"
  done
  [ -z "$alive" ] && break
  sleep 0.05
done
[ -z "$alive" ] || { echo "workers$alive outlived their killed shard" >&2; exit 1; }
if ls "$T"/sharded/shard-0-of-2.* "$T"/sharded/.*shard-0* >/dev/null 2>&1; then
  echo "the killed shard left files: $(ls -a "$T/sharded")" >&2
  exit 1
fi
after=$(sha256sum "$T"/sharded/shard-1-of-2.*)
[ "$before" = "$after" ] || { echo "killing shard 0 changed shard 1's files" >&2; exit 1; }
# Merging now refuses: shard 0 is missing.
if "$ADIT" campaign merge -q "$T/sharded" --out "$T/partial.json" 2>"$T/merge.err"; then
  echo "merge accepted a campaign without shard 0" >&2
  exit 1
fi
grep -q "shard-0-of-2.json" "$T/merge.err" || { echo "merge did not name the missing shard: $(cat "$T/merge.err")" >&2; exit 1; }

# Shard 0 again, alone; then the merge equals the one-process run.
run --shard 0/2 --jobs 2 --out "$T/sharded"
"$ADIT" campaign merge -q "$T/sharded" --out "$T/report.json" --csv "$T/merged.csv"
"$ADIT" campaign merge -q "$T/one" --out "$T/one.json" --csv "$T/one.csv"
diff <(rows "$T/one.csv") <(rows "$T/merged.csv") || { echo "rows differ after the re-run" >&2; exit 1; }
[ "$(counts "$T/one.json")" = "$(counts "$T/report.json")" ] || { echo "counts differ after the re-run" >&2; exit 1; }
echo "killed shard 0 (workers $workers) mid-run; re-run alone, merge equals the one-process run:"
rows "$T/merged.csv"
