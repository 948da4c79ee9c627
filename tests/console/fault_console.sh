#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Fault test of the whole loop: `adit simulate --live` drives a robot into a real `adit serve`,
# the server is killed (SIGKILL) mid-run and restarted on the same port and database; the robot
# reconnects and resends what was not acknowledged. Afterwards the database must hold every
# message of the run exactly once: seqs 1..N without a gap (a lost row) or a repeat (the
# primary key), and the simulation must finish normally.
#
#   tests/console/fault_console.sh ADIT MAP WORK
set -euo pipefail
ADIT=$1 MAP=$2 WORK=$3
# Deadlines x ADIT_TEST_SLOWDOWN (10 in sanitizer and Debug builds, which load the map slower).
SLOWDOWN=${ADIT_TEST_SLOWDOWN:-1}
rm -rf "$WORK" && mkdir -p "$WORK"
server_pid="" sim_pid=""
cleanup() {
  for p in $sim_pid $server_pid; do kill -TERM "$p" 2>/dev/null && wait "$p" 2>/dev/null; done
  true
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
# The first start takes any free port (0) and reads the one announced (a port probed here could be
# taken while the server loads its map); the restart keeps it.
port=0

# One token file for both starts: the robot's credential must still hold after the restart.
echo "fault-test:$(od -An -N16 -tx1 /dev/urandom | tr -d ' \n')" > "$WORK/token"
start_server() {
  : > "$WORK/serve.log"
  "$ADIT" serve --map "$MAP" --listen "127.0.0.1:$port" --db "sqlite:$WORK/centre.db" --token-file "$WORK/token" -q \
    2>> "$WORK/serve.log" &
  server_pid=$!
  for _ in $(seq $((600 * SLOWDOWN))); do
    if grep -q 'http://' "$WORK/serve.log"; then
      port=$(grep -o 'http://127.0.0.1:[0-9]*' "$WORK/serve.log" | head -1 | sed 's#.*:##')
      return 0
    fi
    kill -0 "$server_pid" 2>/dev/null || fail "adit serve exited: $(cat "$WORK/serve.log")"
    sleep 0.1
  done
  fail "adit serve did not start"
}
stored() { python3 -c 'import sqlite3, sys; print(sqlite3.connect(sys.argv[1]).execute("select count(*) from messages").fetchone()[0])' "$WORK/centre.db"; }

start_server
scenario=$(dirname "$MAP")/scenarios/district_rescue.yaml
# A robot with a wrong credential is refused at once with the centre's reason (exit 2), not retried.
echo "not-the-token-0123456789" > "$WORK/wrong_token"
set +e
"$ADIT" simulate "$scenario" --live "ws://127.0.0.1:$port" --live-token-file "$WORK/wrong_token" -q > /dev/null 2> "$WORK/wrong.log"
code=$?
set -e
[ "$code" -eq 2 ] || fail "a wrong robot credential: exit $code, expected 2: $(cat "$WORK/wrong.log")"
grep -q "refused the connection (401): wrong credential for /ws/robot" "$WORK/wrong.log" ||
  fail "a wrong robot credential: no reason given: $(cat "$WORK/wrong.log")"
echo "a wrong credential: $(tail -1 "$WORK/wrong.log")"
# Paced at 20x (about 15 s of wall time for the run) so that the kill below, at about 1.5 s,
# finds it mid-run even when this script's polls are slow on a loaded machine.
"$ADIT" simulate "$scenario" --live "ws://127.0.0.1:$port" --live-speed 20 --live-flush $((30 * SLOWDOWN)) \
  --robot-id faulty --live-token-file "$WORK/token" -q > "$WORK/sim.json" 2> "$WORK/sim.log" &
sim_pid=$!
# Kill the centre once the robot has stored a few hundred messages, while it is still running:
# the robot is frozen (SIGSTOP) to read the count and to check that it has not finished, then
# thawed and the centre killed at once, with the robot's messages in flight.
for _ in $(seq $((600 * SLOWDOWN))); do [ "$(stored)" -ge 300 ] && break; sleep 0.05; done
kill -STOP "$sim_pid" 2>/dev/null || fail "the run ended before the fault: $(tail -5 "$WORK/sim.log")"
# (a run that exited is a zombie until waited for, and SIGSTOP to a zombie succeeds)
[ "$(awk '{print $3}' "/proc/$sim_pid/stat")" != Z ] || fail "the run ended before the fault: $(tail -5 "$WORK/sim.log")"
before=$(stored)
[ "$before" -ge 300 ] || fail "only $before messages stored after $((30 * SLOWDOWN)) s"
kill -CONT "$sim_pid"
kill -KILL "$server_pid"
wait "$server_pid" 2>/dev/null || true
echo "killed the centre after $before stored messages"
sleep 1
start_server
echo "restarted on port $port"
set +e
wait "$sim_pid"
code=$?
set -e
sim_pid=""
[ "$code" -eq 0 ] || fail "adit simulate --live exited with $code: $(tail -5 "$WORK/sim.log")"
python3 - "$WORK/centre.db" "$before" <<'PY' || fail "messages lost or repeated"
import sqlite3, sys
db = sqlite3.connect(sys.argv[1])
seqs = [s for (s,) in db.execute("select seq from messages where robot = 'faulty' order by seq")]
tele = db.execute("select count(*), count(distinct seq) from telemetry where robot = 'faulty'").fetchone()
print(f"{len(seqs)} messages, seq {seqs[0]}..{seqs[-1]}, {tele[0]} telemetry rows ({tele[1]} distinct); {sys.argv[2]} before the kill")
ok = seqs == list(range(1, len(seqs) + 1)) and tele[0] == tele[1] and len(seqs) > int(sys.argv[2])
sys.exit(0 if ok else 1)
PY
echo PASS
