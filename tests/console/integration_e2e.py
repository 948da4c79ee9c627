#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""The operations console end to end (issue 11): a real `adit serve` and a real
`adit simulate --live`, checked through the HTTP API only (python3 stdlib, no WebSocket needed).

    integration_e2e.py --adit BIN --map MAP --scenario S --fault F [--db sqlite|sqlite-normal|postgresql]
                       [--pg-state DIR] [--live-speed X] [--live-period P] [--workdir DIR]

F is one of
  none     the run goes through undisturbed;
  kill     the server is SIGKILLed mid-run and restarted on the same port and database;
  restart  the server is stopped gracefully (SIGTERM) mid-run and restarted likewise;
  drop     the robot talks to the server through a TCP proxy here, which cuts every connection
           mid-run and refuses new ones for a second;
  commands operator commands: a goal in rock (422 with the reason), a block of a roadway the
           robot's path uses (a `plan` with reason `blocked`, the command accepted and executed).

Every fault ends with the same checks: the stored seqs of the robot are exactly 1..N (no gap,
no duplicate), N is what the robot says the centre acknowledged, /api/robots agrees, and the
last telemetry is the run's end (the status `arrived`, the pose the run's last trajectory
sample). Exit 0 on success, 1 on a failed check (the reason on stderr), 2 on bad usage.
"""
import argparse
import json
import math
import os
import re
import select
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request


class Failure(Exception):
    pass


def check(cond, what):
    if not cond:
        raise Failure(what)


class Server:
    """`adit serve` as a child process; the URL and the token come from its stderr."""

    def __init__(self, args, db, port, log_path, token_file):
        self.args, self.db, self.port, self.log_path = args, db, port, log_path
        # One operator token for every start, as a real centre's token file: the robot's
        # credential (the same file) must still hold after a restart.
        self.token_file = token_file
        self.proc = None
        self.token = None
        self.starts = 0

    def start(self, timeout=120.0):
        # The first start asks for any free port (port 0) and takes the one announced: a port
        # probed here and bound by the server only after its map loaded could be taken in between.
        # Restarts keep it, as a real centre would.
        log = open(self.log_path, "ab")
        self.proc = subprocess.Popen(
            [self.args.adit, "serve", "--map", self.args.map, "--db", self.db,
             "--listen", "127.0.0.1:%d" % self.port, "--token-file", self.token_file, "--quiet"],
            stdout=subprocess.DEVNULL, stderr=log)
        CHILDREN.append(self.proc)
        log.close()
        timeout *= SLOWDOWN
        deadline = time.monotonic() + timeout
        url_re = re.compile(r"adit serve: http://127\.0\.0\.1:(\d+)/")
        token_re = re.compile(r"operator token \([^)]*\): (\S+)")
        while time.monotonic() < deadline:
            # The log accumulates over restarts: the last announcement is this process's.
            with open(self.log_path, encoding="utf-8", errors="replace") as f:
                text = f.read()
            ports, tokens = url_re.findall(text), token_re.findall(text)
            if self.proc.poll() is not None:
                raise Failure("adit serve exited with %d:\n%s" % (self.proc.returncode, text[-2000:]))
            if len(ports) >= self.starts + 1 and len(tokens) >= self.starts + 1:
                if self.port == 0:
                    self.port = int(ports[-1])
                check(int(ports[-1]) == self.port, "adit serve announced port %s, asked %d" % (ports[-1], self.port))
                self.token = tokens[-1]
                self.starts += 1
                return
            time.sleep(0.05)
        raise Failure("adit serve did not announce its URL within %.0f s" % timeout)

    def stop(self, sig):
        if self.proc and self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(timeout=30 * SLOWDOWN)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
                raise Failure("adit serve did not stop within %.0f s of signal %d" % (30 * SLOWDOWN, sig))

    def http(self, method, path, body=None, token=True):
        """(status, parsed JSON) of one request; with the operator token unless `token` is None
        or another string."""
        if token is True:
            token = self.token
        req = urllib.request.Request("http://127.0.0.1:%d%s" % (self.port, path), method=method)
        data = None
        if body is not None:
            data = json.dumps(body).encode()
            req.add_header("Content-Type", "application/json")
        if token:
            req.add_header("Authorization", "Bearer " + token)
        try:
            with urllib.request.urlopen(req, data=data, timeout=30 * SLOWDOWN) as r:
                return r.status, json.loads(r.read().decode())
        except urllib.error.HTTPError as e:
            return e.code, json.loads(e.read().decode() or "null")


class Proxy:
    """A TCP relay 127.0.0.1:listen → 127.0.0.1:target; cut() closes every relayed connection
    and refuses new ones for `pause` seconds (the robot sees a dropped link)."""

    def __init__(self, target):
        self.target = target
        self.sock = socket.socket()
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(16)
        self.port = self.sock.getsockname()[1]
        self.lock = threading.Lock()
        self.pairs = []
        self.refuse_until = 0.0
        self.cuts = 0
        self.accepted = 0
        self.stopping = False
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self):
        while not self.stopping:
            try:
                client, _ = self.sock.accept()
            except OSError:
                return
            if time.monotonic() < self.refuse_until:
                client.close()
                continue
            try:
                upstream = socket.create_connection(("127.0.0.1", self.target), timeout=5)
            except OSError:
                client.close()
                continue
            with self.lock:
                self.pairs.append((client, upstream))
                self.accepted += 1
            threading.Thread(target=self._relay, args=(client, upstream), daemon=True).start()

    def _relay(self, a, b):
        peers = {a: b, b: a}
        try:
            while True:
                ready, _, _ = select.select([a, b], [], [], 0.5)
                for s in ready:
                    data = s.recv(65536)
                    if not data:
                        return
                    peers[s].sendall(data)
        except OSError:
            return
        finally:
            for s in (a, b):
                try:
                    s.close()
                except OSError:
                    pass

    def cut(self, pause=1.0):
        with self.lock:
            self.refuse_until = time.monotonic() + pause
            for a, b in self.pairs:
                for s in (a, b):
                    try:
                        s.shutdown(socket.SHUT_RDWR)
                    except OSError:
                        pass
            self.pairs = []
            self.cuts += 1

    def close(self):
        self.stopping = True
        self.sock.close()


def history(server, robot):
    out, seq = [], 1
    while True:
        status, page = server.http("GET", "/api/history?robot=%s&from_seq=%d&limit=10000" % (robot, seq))
        check(status == 200, "/api/history answered %d: %s" % (status, page))
        if not page:
            return out
        out.extend(page)
        seq = page[-1]["seq"] + 1


def last_seq(server, robot):
    status, robots = server.http("GET", "/api/robots")
    check(status == 200, "/api/robots answered %d" % status)
    for r in robots:
        if r["robot"] == robot:
            return r["last_seq"], r
    return 0, None


# Every deadline here is multiplied by this (--slowdown): a sanitizer or Debug build loads the map
# and plans ten times slower, and its deadlines must not be what fails.
SLOWDOWN = 1.0

# Every child process started (servers, the simulator): whatever way the test ends, none outlives
# it (a failed check used to leave `adit serve` running, loading the next tests' machine).
CHILDREN = []


def wait_for(pred, timeout, what):
    timeout *= SLOWDOWN
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if pred():
            return
        time.sleep(0.05)
    raise Failure("timed out after %.0f s waiting for %s" % (timeout, what))


def seqs_gapless(msgs, what):
    seqs = [m["seq"] for m in msgs]
    check(len(seqs) == len(set(seqs)), "%s: duplicate seqs stored" % what)
    missing = sorted(set(range(1, len(seqs) + 1)) - set(seqs))
    check(seqs == list(range(1, len(seqs) + 1)),
          "%s: stored seqs are not 1..%d (first missing: %s, max %s)" % (what, len(seqs), missing[:10], max(seqs or [0])))
    return len(seqs)


def run(args):
    work = args.workdir or tempfile.mkdtemp(prefix="adit-e2e-")
    os.makedirs(work, exist_ok=True)
    robot = "e2e-" + args.fault
    if args.db == "postgresql":
        with open(os.path.join(args.pg_state, "url"), encoding="utf-8") as f:
            db = f.read().strip()
        robot += "-pg-%d" % os.getpid()  # the throw-away database may hold earlier runs
    elif args.db == "sqlite-normal":
        db = "sqlite:%s?synchronous=normal" % os.path.join(work, "c.db")
    else:
        db = "sqlite:" + os.path.join(work, "c.db")
    for suffix in ("", "-wal", "-shm"):
        if args.db != "postgresql" and os.path.exists(os.path.join(work, "c.db" + suffix)):
            os.remove(os.path.join(work, "c.db" + suffix))
    serve_log = os.path.join(work, "serve.log")
    if os.path.exists(serve_log):  # a previous run's: the announcements are counted per start
        os.remove(serve_log)
    token_file = os.path.join(work, "token")
    with open(token_file, "w") as f:
        f.write("e2e:%s\n" % os.urandom(16).hex())
    server = Server(args, db, 0, serve_log, token_file)
    server.start()
    proxy = Proxy(server.port) if args.fault == "drop" else None
    live_port = proxy.port if proxy else server.port
    run_json = os.path.join(work, "run.json")
    sim_log_path = os.path.join(work, "simulate.log")
    sim_log = open(sim_log_path, "wb")
    t0 = time.monotonic()
    sim = subprocess.Popen(
        [args.adit, "simulate", args.scenario, "--live", "ws://127.0.0.1:%d" % live_port,
         "--live-speed", str(args.live_speed), "--live-period", str(args.live_period), "--robot-id", robot, "--out", run_json,
         "--live-token-file", token_file]
        + (["--live-flush", "1"] if args.fault == "gone" else ["--live-flush", "%g" % (30 * SLOWDOWN)])
        # The operator's block must act before the robot reaches crosscut-90: the robot waits at
        # its start until the operator resumes it, instead of the test racing the wall clock.
        + (["--live-hold"] if args.fault == "commands" else []),
        stdout=subprocess.DEVNULL, stderr=sim_log)
    CHILDREN.append(sim)
    sim_log.close()
    try:
        checks = []
        if args.fault in ("kill", "restart", "drop"):
            # Mid-run: once the centre holds a few dozen messages of the robot.
            wait_for(lambda: last_seq(server, robot)[0] >= 40, 60, "the first 40 messages")
            before = last_seq(server, robot)[0]
            if proxy:
                proxy.cut(1.0)
            else:
                server.stop(signal.SIGKILL if args.fault == "kill" else signal.SIGTERM)
                time.sleep(0.5)  # the robot's link sees the dead centre and backs off
                server.start()
            checks.append("fault after seq %d" % before)
        if args.fault == "commands":
            checks += operator_commands(server, robot)
        if args.fault == "gone":
            # The centre dies for good mid-run: what it never acknowledged is lost with the robot's
            # process, and the run must say so and fail (exit 1), not end as a success.
            wait_for(lambda: last_seq(server, robot)[0] >= 40, 60, "the first 40 messages")
            server.stop(signal.SIGKILL)
            rc = sim.wait(timeout=args.timeout * SLOWDOWN)
            with open(sim_log_path, encoding="utf-8", errors="replace") as f:
                sim_text = f.read()
            check(rc == 1, "adit simulate exited with %d after losing its console:\n%s" % (rc, sim_text[-2000:]))
            check(re.search(r"live: \d+ messages not acknowledged after 1 s, lost", sim_text),
                  "adit simulate did not say what it lost:\n" + sim_text[-2000:])
            server.start()  # what was stored before the kill is a gapless prefix
            n = seqs_gapless(history(server, robot), robot)
            server.stop(signal.SIGTERM)
            print("gone: exit 1, %d messages stored before the kill, the rest reported lost" % n)
            return
        rc = sim.wait(timeout=args.timeout * SLOWDOWN)
    finally:
        if sim.poll() is None:
            sim.kill()
            sim.wait()
    wall = time.monotonic() - t0
    with open(sim_log_path, encoding="utf-8", errors="replace") as f:
        sim_text = f.read()
    try:
        check(rc == 0, "adit simulate exited with %d:\n%s" % (rc, sim_text[-2000:]))
        check("not acknowledged" not in sim_text, "the robot ended with unacknowledged messages:\n" + sim_text[-2000:])
        m = re.search(r"live: (\d+) messages acknowledged, (\d+) reconnections", sim_text)
        check(m, "adit simulate did not report its acknowledgements:\n" + sim_text[-2000:])
        acked, reconnections = int(m.group(1)), int(m.group(2))
        if args.fault in ("kill", "restart", "drop"):
            check(reconnections >= 1, "the robot never reconnected after the fault (%s)" % args.fault)
        msgs = history(server, robot)
        n = seqs_gapless(msgs, robot)
        check(n == acked, "stored %d messages, the robot saw %d acknowledged" % (n, acked))
        ls, record = last_seq(server, robot)
        check(ls == n, "/api/robots last_seq %d, history holds %d" % (ls, n))
        with open(run_json, encoding="utf-8") as f:
            result = json.load(f)
        telemetry = [m for m in msgs if m["type"] == "telemetry"]
        check(telemetry, "no telemetry stored")
        last = telemetry[-1]
        end = result["trajectory"][-1]
        if result["outcome"] == "arrived":
            check(last["status"] == "arrived", "the last telemetry says %r, the run arrived" % last["status"])
        dist = math.dist(last["pose"], [end["x"], end["y"], end["z"]])
        check(dist <= args.pose_tolerance,
              "the last telemetry pose %s is %.3f m from the run's end %s" % (last["pose"], dist, [end["x"], end["y"], end["z"]]))
        check(record is not None and record["telemetry"]["seq"] == last["seq"],
              "/api/robots' telemetry is not the last stored one")
        if args.fault == "commands":
            checks += check_commands_after(server, robot, msgs)
        stats = {
            "fault": args.fault, "db": args.db, "messages": n, "telemetry": len(telemetry),
            "reconnections": reconnections, "outcome": result["outcome"], "wall_s": round(wall, 1),
            "server_starts": server.starts, "checks": checks,
        }
        if proxy:
            stats["proxy_connections"] = proxy.accepted
        print(json.dumps(stats))
    finally:
        if proxy:
            proxy.close()
        server.stop(signal.SIGTERM)
        if server.proc.returncode not in (0, None):
            raise Failure("adit serve exited with %d on SIGTERM" % server.proc.returncode)


def operator_commands(server, robot):
    """While the robot holds at its start (--live-hold): refusals first (nothing stored), then a
    block on its path, executed; then the resume that lets it go."""
    wait_for(lambda: last_seq(server, robot)[1] is not None and last_seq(server, robot)[1].get("plan"),
             60, "the robot's first plan")
    out = []
    # 401 without the token, 422 for a goal in rock (the survey's roadways are 4 m wide, z = -1.5
    # here; (60, 30, -1.5) lies between the main and the return airway: solid rock).
    status, body = server.http("POST", "/api/commands", {"robot": robot, "kind": "pause"}, None)
    check(status == 401, "a command without the token: %d %s" % (status, body))
    status, body = server.http("POST", "/api/commands", {"robot": robot, "kind": "goal", "goal": [60, 30, -1.5]},
                               server.token)
    check(status == 422 and "error" in body, "a goal in rock: %d %s (want 422 with the reason)" % (status, body))
    out.append("goal in rock: 422 %s" % body["error"])
    status, body = server.http("POST", "/api/commands", {"robot": robot, "kind": "block", "roadway": "no-such-roadway"},
                               server.token)
    check(status == 422, "an unknown roadway: %d %s (want 422)" % (status, body))
    status, cmds = server.http("GET", "/api/commands?robot=" + robot)
    check(status == 200 and cmds == [], "refused commands were stored: %s" % cmds)
    status, body = server.http("POST", "/api/commands", {"robot": robot, "kind": "block", "roadway": "crosscut-90"},
                               server.token)
    check(status == 202 and body.get("status") == "pending", "block crosscut-90: %d %s" % (status, body))
    block_id = body["command_id"]
    out.append("block crosscut-90: command %s" % block_id)

    def block_status():
        status, cmds = server.http("GET", "/api/commands?robot=" + robot)
        check(status == 200, "/api/commands answered %d" % status)
        return [c["status"] for c in cmds if c["command_id"] == block_id]

    wait_for(lambda: block_status() == ["executed"], 60, "the held robot to execute the block")
    status, body = server.http("POST", "/api/commands", {"robot": robot, "kind": "resume"}, server.token)
    check(status == 202, "resume: %d %s" % (status, body))
    return out


def check_commands_after(server, robot, msgs):
    status, cmds = server.http("GET", "/api/commands?robot=" + robot)
    check(status == 200 and sorted(c["kind"] for c in cmds) == ["block", "resume"], "the command log: %d %s" % (status, cmds))
    check(all(c["status"] == "executed" for c in cmds), "the commands ended %s" % cmds)
    c = [c for c in cmds if c["kind"] == "block"][0]
    check(c.get("operator"), "the command log does not say who issued the block: %s" % c)
    blocked = [m for m in msgs if m["type"] == "plan" and m["reason"] == "blocked"]
    check(blocked, "no plan with reason 'blocked' after the block (plans: %s)" %
          [m["reason"] for m in msgs if m["type"] == "plan"])
    results = [m["result"] for m in msgs if m["type"] == "command_result" and m["command_id"] == c["command_id"]]
    check(results[:2] == ["accepted", "executed"], "the robot's answers to the block: %s" % results)
    # The plan made for the block leaves crosscut-90 (x = 90, y = 0..40) alone.
    through = [p for p in blocked[0]["path"] if abs(p[0] - 90.0) < 2.5 and 5.0 < p[1] < 35.0]
    check(not through, "the plan made for the block still crosses crosscut-90 at %s" % through[:3])
    return ["block executed: %s" % c.get("reason", ""), "plans with reason blocked: %d" % len(blocked)]


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--adit", required=True)
    p.add_argument("--map", required=True)
    p.add_argument("--scenario", required=True)
    p.add_argument("--fault", choices=["none", "kill", "restart", "drop", "commands", "gone"], default="none")
    p.add_argument("--db", choices=["sqlite", "sqlite-normal", "postgresql"], default="sqlite")
    p.add_argument("--pg-state", help="the postgres_fixture.sh state dir (with --db postgresql)")
    p.add_argument("--live-speed", type=float, default=0.0)
    p.add_argument("--live-period", type=float, default=0.1)
    p.add_argument("--pose-tolerance", type=float, default=0.01)
    p.add_argument("--timeout", type=float, default=240.0)
    p.add_argument("--slowdown", type=float, default=1.0,
                   help="multiply every deadline (10 for sanitizer and Debug builds)")
    p.add_argument("--workdir")
    args = p.parse_args()
    global SLOWDOWN
    SLOWDOWN = args.slowdown
    if args.db == "postgresql" and not args.pg_state:
        p.error("--db postgresql needs --pg-state")
    try:
        run(args)
    except Failure as e:
        print("integration_e2e (%s, %s): FAILED: %s" % (args.fault, args.db, e), file=sys.stderr)
        return 1
    finally:
        for child in CHILDREN:
            if child.poll() is None:
                child.kill()
                child.wait()
    return 0


if __name__ == "__main__":
    sys.exit(main())
