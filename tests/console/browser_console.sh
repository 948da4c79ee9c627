#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# The console's page in headless Chromium, offline, against a real `adit serve`: a robot
# (adit_console_feed) walks a survey roadway through the protocol, then the page must show it
# where its last pose says (the robot's row: data-pose = the feed's last pose, data-drawn = the
# 3-D marker's position = data-pose), with no script error, WebGL on, and a screenshot showing the
# robot's colour. Then a click on the top view (the page's `#goal-click=X,Y`, a real click event
# in goal mode) must reach a navigated robot (`adit simulate --live`), which accepts the goal and
# replans toward it. Then the control room: the page's E-STOP button stops that robot, which
# acknowledges it (the banner shows it engaged, the telemetry says "estop"), the page's release
# ends it; the robot's process killed, the centre raises a lost-link alarm the page shows and an
# operator's click acknowledges (stored with who and when). Finally SIGTERM must stop the server
# cleanly (exit 0). Also how the docs' screenshots are made:
#
#   tests/console/browser_console.sh ADIT FEED MAP WORK [CHECK_PNG] [SCREENSHOT] [ALARM_SCREENSHOT]
set -euo pipefail
# Deadlines x ADIT_TEST_SLOWDOWN (10 in sanitizer and Debug builds).
SLOWDOWN=${ADIT_TEST_SLOWDOWN:-1}
ADIT=$1 FEED=$2 MAP=$3 WORK=$4 CHECK_PNG=${5:-} SHOT=${6:-$4/console.png} ALARM_SHOT=${7:-$4/console-alarm.png}
CHROMIUM=${CHROMIUM:-/usr/bin/chromium}
rm -rf "$WORK" && mkdir -p "$WORK"
server_pid="" sim_pid=""
# Whatever way the script ends, no child outlives it (a failed check left the simulation running).
cleanup() {
  for p in $sim_pid $server_pid; do
    if kill -0 "$p" 2>/dev/null; then kill -TERM "$p"; wait "$p" || true; fi
  done
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

echo "console-test:0123456789abcdef0123" > "$WORK/token"
"$ADIT" serve --map "$MAP" --listen 127.0.0.1:0 --db "sqlite:$WORK/centre.db" --token-file "$WORK/token" -q \
  2> "$WORK/serve.log" &
server_pid=$!
for _ in $(seq $((600 * SLOWDOWN))); do
  grep -q 'http://' "$WORK/serve.log" 2>/dev/null && break
  kill -0 "$server_pid" 2>/dev/null || fail "adit serve exited: $(cat "$WORK/serve.log")"
  sleep 0.2
done
hostport=$(grep -o 'http://[0-9.]*:[0-9]*' "$WORK/serve.log" | head -1 | sed 's#http://##')
[ -n "$hostport" ] || fail "adit serve printed no URL"
grep -q "operator token (console-test): 0123456789abcdef0123" "$WORK/serve.log" || fail "the token file's label and token are not printed"
echo "serving on $hostport"

"$FEED" "$hostport" --token 0123456789abcdef0123 --robots 1 --hz 20 --seconds 4 > "$WORK/feed.txt"
last=$(awk '$1 == "last" && $2 == "r1" {print $3}' "$WORK/feed.txt")
[ -n "$last" ] || fail "the feed reported no last pose"
echo "robot r1 last pose $last"

flags=(--headless --no-sandbox --disable-gpu --enable-unsafe-swiftshader --use-angle=swiftshader --no-first-run
       --no-default-browser-check --disable-background-networking --disable-component-update --disable-sync
       --disable-default-apps --disable-extensions --mute-audio --hide-scrollbars --window-size=1400,900
       --virtual-time-budget=5000)
chromium() {
  local profile="$WORK/chromium-$1"; shift
  rm -rf "$profile"; mkdir -p "$profile"
  timeout $((180 * SLOWDOWN)) "$CHROMIUM" "${flags[@]}" --user-data-dir="$profile" "$@" 2>> "$WORK/chromium.log"
  rm -rf "$profile"
}
# The virtual-time budget does not wait for the WebSocket snapshot that draws the robot's row: load
# the page again until the row is there (bounded), instead of failing on a slow first frame.
for _ in 1 2 3 4 5; do
  chromium dom --dump-dom "http://$hostport/#token=0123456789abcdef0123" > "$WORK/dom.html"
  grep -q '<tr data-robot="r1"' "$WORK/dom.html" && break
done
root=$(grep -o '<html[^>]*>' "$WORK/dom.html" | head -1 || true)
row=$(grep -o '<tr data-robot="r1"[^>]*>' "$WORK/dom.html" | head -1 || true)
[ -n "$row" ] || fail "the page drew no row for robot r1 in 5 loads: $root"
echo "root: $root"
echo "row:  $row"
[[ "$root" == *'data-ready="1"'* ]] || fail "the page did not start"
[[ "$root" == *'data-errors="0"'* ]] || fail "the page recorded errors: $(grep -o '<pre id="errors">[^<]*' "$WORK/dom.html")"
[[ "$root" == *'data-webgl="1"'* ]] || fail "no WebGL: the 3-D view is off"
[[ "$root" == *'data-robots="1"'* ]] || fail "the page shows no robot"
pose=$(sed -n 's/.*data-pose="\([^"]*\)".*/\1/p' <<< "$row")
drawn=$(sed -n 's/.*data-drawn="\([^"]*\)".*/\1/p' <<< "$row")
python3 - "$last" "$pose" "$drawn" <<'PY' || fail "the robot is not drawn where its pose says"
import sys
last, pose, drawn = ([float(v) for v in a.split(',')] for a in sys.argv[1:4])
ok = all(abs(a - b) < 1e-3 for a, b in zip(last, pose)) and all(abs(a - b) < 1e-6 for a, b in zip(pose, drawn))
print(f"feed {last}, page pose {pose}, marker {drawn}")
sys.exit(0 if ok and len(pose) == 3 and len(drawn) == 3 else 1)
PY
# Without the operator token the page reads nothing of the mine and asks for it.
chromium notoken --dump-dom "http://$hostport/" > "$WORK/notoken.html"
grep -q 'id="conn"[^>]*>enter the operator token<' "$WORK/notoken.html" || fail "without a token the page does not ask for one"
if grep -q '<tr data-robot=' "$WORK/notoken.html"; then fail "without a token the page shows the robots"; fi
echo "without a token: the page asks for it and shows no robot"
chromium shot --screenshot="$SHOT" "http://$hostport/#token=0123456789abcdef0123"
[ -s "$SHOT" ] || fail "chromium wrote no screenshot"
if [ -n "$CHECK_PNG" ]; then
  "$CHECK_PNG" check-png "$SHOT" 4fc3f7 20 || fail "the screenshot does not show the robot's colour"
fi
echo "screenshot: $SHOT"

# 2. A goal set by a click on the top view: a navigated robot (adit simulate --live) gets it,
#    accepts it and replans toward it (a `plan` with reason "goal"). The goal lies 125 m ahead so
#    the robot is still driving when step 3 presses its e-stop (one 24 m ahead was reached in 28 s,
#    and the simulation had ended before the page's e-stop reached it).
scenario=$(dirname "$MAP")/scenarios/district_inspection.yaml
"$ADIT" simulate "$scenario" --live "ws://$hostport" --live-speed 1 --live-token-file "$WORK/token" -q > "$WORK/sim.json" \
  2> "$WORK/sim.log" &
sim_pid=$!
api() { python3 -c 'import sys, urllib.request; print(urllib.request.urlopen(urllib.request.Request("http://" + sys.argv[1] + sys.argv[2], headers={"Authorization": "Bearer 0123456789abcdef0123"})).read().decode())' "$hostport" "$1"; }
robot_known() { api /api/robots | python3 -c 'import json, sys; sys.exit(0 if any(r["robot"] == "district_inspection" and r["telemetry"] for r in json.load(sys.stdin)) else 1)'; }
for _ in $(seq $((300 * SLOWDOWN))); do robot_known && break; sleep 0.2; done
robot_known || fail "the simulated robot never reported: $(cat "$WORK/sim.log")"
# The click waits in the page for the robot's snapshot, which the virtual-time budget does not wait
# for (as above): load it again until the page reports an accepted command (bounded; a command
# sent by an earlier load is harmless, the robot takes the last goal and the check reads that id).
for _ in 1 2 3 4 5; do
  chromium click --dump-dom "http://$hostport/#token=0123456789abcdef0123&robot=district_inspection&goal-click=150,0" > "$WORK/click.html"
  grep -q '<html[^>]*data-last-command="[0-9]' "$WORK/click.html" && break
  grep -q '<html[^>]*data-errors="0"' "$WORK/click.html" || break
done
click_root=$(grep -o '<html[^>]*>' "$WORK/click.html" | head -1)
echo "after the click: $click_root"
[[ "$click_root" == *'data-errors="0"'* ]] || fail "the page recorded errors: $(grep -o '<pre id="errors">[^<]*' "$WORK/click.html")"
command_id=$(sed -n 's/.*data-last-command="\([0-9]*\)".*/\1/p' <<< "$click_root")
[ -n "$command_id" ] || fail "the click sent no accepted command: $(grep -o 'id="answer"[^<]*' "$WORK/click.html")"
replanned=""
for _ in $(seq $((100 * SLOWDOWN))); do
  replanned=$(api "/api/history?robot=district_inspection&limit=10000" | python3 -c '
import json, sys
cid = int(sys.argv[1]); msgs = json.load(sys.stdin)
results = [m["result"] for m in msgs if m["type"] == "command_result" and m["command_id"] == cid]
plans = [m for m in msgs if m["type"] == "plan" and m["reason"] == "goal"]
if "accepted" in results and plans:
    print("command %d %s, replanned toward %s" % (cid, "/".join(results), plans[-1]["path"][-1]))' "$command_id")
  [ -n "$replanned" ] && break
  sleep 0.2
done
if [ -z "$replanned" ]; then
  kill -TERM "$sim_pid" 2>/dev/null || true
  wait "$sim_pid" 2>/dev/null || true
  # What the centre holds of it, and what the robot said: the reason is in one of them.
  api "/api/history?robot=district_inspection&limit=10000" | python3 -c '
import json, sys
msgs = json.load(sys.stdin)
print("history: %d messages, last seq %s" % (len(msgs), msgs[-1]["seq"] if msgs else "-"))
for m in msgs:
    if m["type"] in ("command_result", "plan", "event"):
        print("  seq %s t %s %s %s" % (m["seq"], m["t"], m["type"], m.get("result", m.get("reason", ""))))' || true
  api "/api/commands?robot=district_inspection" || true
  echo "simulate's log:"; tail -n 20 "$WORK/sim.log"
  echo "the centre's log:"; tail -n 20 "$WORK/serve.log"
  fail "the robot did not accept and replan toward the clicked goal (command $command_id)"
fi
echo "$replanned"

# 3. The e-stop, pressed in the page: the robot acknowledges it (executed), the page shows it
#    engaged until the page's release is executed too.
# page NAME HASH CHECK...: load until the root element matches every CHECK (bounded; the
# virtual-time budget does not wait for the snapshot and the history, as above).
page() {
  local name=$1 hash=$2 check all
  shift 2
  for _ in 1 2 3 4 5; do
    chromium "$name" --dump-dom "http://$hostport/#token=0123456789abcdef0123&robot=district_inspection$hash" > "$WORK/$name.html"
    all=1
    for check in "$@"; do grep -q "<html[^>]*$check" "$WORK/$name.html" || all=0; done
    [ "$all" = 1 ] && return 0
    grep -q '<html[^>]*data-errors="0"' "$WORK/$name.html" || break
  done
  echo "$name: $(grep -o '<html[^>]*>' "$WORK/$name.html" | head -1)"
  fail "the page did not show $*: $(grep -o '<pre id="errors">[^<]*' "$WORK/$name.html"; grep -o 'id="answer"[^<]*' "$WORK/$name.html")"
}
estop_of() { api /api/robots | python3 -c '
import json, sys
for r in json.load(sys.stdin):
    if r["robot"] == "district_inspection":
        e = r.get("estop")
        print("none" if e is None else "engaged" if e["engaged"] else e["status"])' ; }
wait_estop() {  # wait_estop STATE
  for _ in $(seq $((100 * SLOWDOWN))); do [ "$(estop_of)" = "$1" ] && return 0; sleep 0.2; done
  kill -0 "$sim_pid" 2>/dev/null || fail "the simulated robot ended before its e-stop was '$1': $(grep -o '"outcome": "[a-z_]*"' "$WORK/sim.json")"
  fail "the robot's e-stop is '$(estop_of)', not '$1': $(tail -n 5 "$WORK/sim.log")"
}
page estop "&estop-click=1" 'data-last-command="[0-9]'
wait_estop engaged
status=$(api /api/robots | python3 -c 'import json, sys; print([r for r in json.load(sys.stdin) if r["robot"] == "district_inspection"][0]["telemetry"]["status"])')
for _ in $(seq $((50 * SLOWDOWN))); do
  [ "$status" = estop ] && break
  sleep 0.2
  status=$(api /api/robots | python3 -c 'import json, sys; print([r for r in json.load(sys.stdin) if r["robot"] == "district_inspection"][0]["telemetry"]["status"])')
done
[ "$status" = estop ] || fail "the e-stopped robot reports status '$status', not estop"
page banner "" 'data-estops="district_inspection:engaged"' 'data-series="[1-9][0-9]'
grep -q '<div data-robot="district_inspection">E-STOP district_inspection: engaged, acknowledged by the robot' "$WORK/banner.html" \
  || fail "the page shows no e-stop banner"
series=$(grep -o '<html[^>]*>' "$WORK/banner.html" | sed -n 's/.*data-series="\([0-9]*\)".*/\1/p')
[ "${series:-0}" -ge 10 ] || fail "the page's time-series holds ${series:-0} samples with a clearance"
grep -q '<html[^>]*data-scale="[0-9.]*,[0-9.]*"' "$WORK/banner.html" || fail "the top view has no scale bar"
grep -q '<html[^>]*data-scale3d="[0-9.]*,[0-9.]*"' "$WORK/banner.html" || fail "the 3-D view has no scale bar"
echo "e-stop engaged, acknowledged by the robot, shown in the page ($series samples of speed and clearance)"
# A retry of the page clicks again: once the first click's release is executed, the second is
# refused (409, not e-stopped). Either shows the click went through; the robot's state decides.
page release "&estop-release-click=1" 'data-last-command="\([0-9]\|refused 409\)'
wait_estop none
echo "e-stop released by the page"

# 4. An alarm: the robot's process killed, the centre raises a lost link; the page shows it and
#    a click acknowledges it, stored with the operator's name and time.
kill -KILL "$sim_pid" 2>/dev/null || true
wait "$sim_pid" 2>/dev/null || true
sim_pid=""
alarm=""
for _ in $(seq $((100 * SLOWDOWN))); do
  alarm=$(api "/api/alarms?robot=district_inspection&open=1" | python3 -c '
import json, sys
a = [a for a in json.load(sys.stdin) if a["kind"] == "lost_link" and not a["acked_at"]]
print(a[-1]["alarm_id"] if a else "")')
  [ -n "$alarm" ] && break
  sleep 0.2
done
[ -n "$alarm" ] || fail "no lost-link alarm after the robot's process was killed"
page alarm "" 'data-unacked="[1-9]'
grep -q "<li class=\"critical\" data-alarm-id=\"$alarm\" data-kind=\"lost_link\">CRITICAL district_inspection lost link" "$WORK/alarm.html" \
  || fail "the page does not list alarm $alarm"
chromium alarmshot --screenshot="$ALARM_SHOT" "http://$hostport/#token=0123456789abcdef0123&robot=district_inspection"
[ -s "$ALARM_SHOT" ] || fail "chromium wrote no alarm screenshot"
if [ -n "$CHECK_PNG" ]; then
  "$CHECK_PNG" check-png "$ALARM_SHOT" ff7b72 20 || fail "the alarm screenshot does not show the critical alarm's colour"
fi
page ack "&ack-click=all" 'data-last-ack="[0-9]'
acked=$(api "/api/alarms?robot=district_inspection" | python3 -c '
import json, sys
a = [a for a in json.load(sys.stdin) if a["alarm_id"] == int(sys.argv[1])][0]
print("%s at %s" % (a["acked_by"], a["acked_at"]) if a["acked_by"] else "")' "$alarm")
[[ "$acked" == console-test\ at\ 20* ]] || fail "alarm $alarm is not acknowledged by console-test: '$acked'"
python3 - "$WORK/centre.db" "$alarm" <<'PY' || fail "the acknowledgement is not in the database"
import sqlite3, sys
row = sqlite3.connect(sys.argv[1]).execute("SELECT kind, severity, acked_by, acked_at FROM alarms WHERE alarm_id = ?", (int(sys.argv[2]),)).fetchone()
print("stored:", row)
sys.exit(0 if row and row[0] == "lost_link" and row[1] == "critical" and row[2] == "console-test" and row[3] else 1)
PY
page acked "&layers-off=labels,trail" "data-unacked=\"0\"" 'data-layers="rock,plan,sensed,tracks,events"'
grep -q "acknowledged by console-test at" "$WORK/acked.html" || fail "the page does not show who acknowledged the alarm"
# The names layer off: no roadway name is drawn in the 3-D view.
names=$(grep -o '<span class="roadway"[^>]*>' "$WORK/acked.html" | wc -l)
hidden=$(grep -o '<span class="roadway" style="[^"]*display: none[^"]*"' "$WORK/acked.html" | wc -l)
[ "$names" -gt 0 ] && [ "$names" -eq "$hidden" ] || fail "with the names layer off, $((names - hidden)) of $names roadway names are drawn"
echo "alarm $alarm (lost link) shown, acknowledged by $acked; screenshot: $ALARM_SHOT"

kill -TERM "$server_pid"
set +e
wait "$server_pid"
code=$?
set -e
server_pid=""
[ "$code" -eq 0 ] || fail "adit serve exited with $code on SIGTERM"
grep -q "stopped" "$WORK/serve.log" || fail "adit serve did not report a clean stop"
echo "PASS"
