#!/bin/sh
# SPDX-License-Identifier: BSD-3-Clause
# A throw-away PostgreSQL server for the store's tests and benchmark (issue 11).
#
#   postgres_fixture.sh start STATE_DIR   initdb in a fresh temp dir, start on a free loopback
#                                         port; writes STATE_DIR/url (postgresql://...) and
#                                         STATE_DIR/pgdata (the temp dir's path)
#   postgres_fixture.sh restart STATE_DIR a fast shutdown and a start on the same port and data
#                                         (the store's reconnection test)
#   postgres_fixture.sh stop STATE_DIR    stops that server by its PID, removes the temp dir
#
# PostgreSQL refuses to run as root: as root the server runs as the `postgres` system account
# (Debian's postgresql package creates it). Only loopback TCP and a socket inside the temp dir:
# nothing of a system cluster is touched. A start that fails cleans up after itself.
set -eu

action=${1:?usage: postgres_fixture.sh start|restart|stop STATE_DIR}
state=${2:?usage: postgres_fixture.sh start|restart|stop STATE_DIR}

bindir=""
for d in "${PG_BINDIR:-}" /usr/lib/postgresql/15/bin /usr/lib/postgresql/*/bin; do
  if [ -n "$d" ] && [ -x "$d/initdb" ] && [ -x "$d/pg_ctl" ]; then bindir=$d; break; fi
done
[ -n "$bindir" ] || { echo "postgres_fixture: no initdb/pg_ctl found" >&2; exit 2; }

as_db_user() {
  if [ "$(id -u)" -eq 0 ]; then runuser -u postgres -- "$@"; else "$@"; fi
}

stop_postmaster() {  # $1: the temp dir (the cluster is in $1/data)
  pidfile="$1/data/postmaster.pid"
  if [ -f "$pidfile" ]; then
    pid=$(head -n 1 "$pidfile")
    # SIGINT: PostgreSQL's fast shutdown (abort clients, checkpoint, exit).
    kill -INT "$pid" 2>/dev/null || true
    i=0
    while kill -0 "$pid" 2>/dev/null && [ $i -lt 300 ]; do sleep 0.1; i=$((i + 1)); done
    if kill -0 "$pid" 2>/dev/null; then kill -KILL "$pid" 2>/dev/null || true; fi
  fi
}

stop_server() {  # $1: the temp dir
  stop_postmaster "$1"
  rm -rf "$1"
}

start_postmaster() {  # $1: the temp dir, $2: the port
  as_db_user "$bindir/pg_ctl" -D "$1/data" -w -t 60 -l "$1/server.log" \
    -o "-p $2 -k $1 -c listen_addresses=127.0.0.1" start >/dev/null 2>&1
}

case "$action" in
  start)
    mkdir -p "$state"
    if [ -f "$state/pgdata" ]; then stop_server "$(cat "$state/pgdata")"; fi
    rm -f "$state/url" "$state/pgdata"
    base=${TMPDIR:-/tmp}
    # As root the server runs as `postgres`, which must reach the temp dir: a private TMPDIR
    # (under /root, say) would not do.
    if [ "$(id -u)" -eq 0 ] && ! runuser -u postgres -- test -x "$base"; then base=/tmp; fi
    tmp=$(mktemp -d "$base/adit-pg.XXXXXX")
    trap 'stop_server "$tmp"' EXIT INT TERM
    if [ "$(id -u)" -eq 0 ]; then chown postgres: "$tmp"; fi
    chmod 700 "$tmp"
    password="adit-test-$(od -An -N6 -tx1 /dev/urandom | tr -d ' \n')"
    printf '%s\n' "$password" > "$tmp/pwfile"
    if [ "$(id -u)" -eq 0 ]; then chown postgres: "$tmp/pwfile"; fi
    as_db_user "$bindir/initdb" -D "$tmp/data" -U adit --pwfile="$tmp/pwfile" -A scram-sha-256 \
      --no-sync -E UTF8 --locale=C >"$tmp/initdb.log" 2>&1 ||
      { cat "$tmp/initdb.log" >&2; exit 1; }
    rm -f "$tmp/pwfile"
    # A free port: try random ports until the server starts (no race with a probe). Below Linux's
    # ephemeral range (32768-60999), so that `restart` finds its port free again: no client
    # socket of a parallel test is ever given one of these in the gap.
    tries=0
    while :; do
      port=$((20000 + $(od -An -N2 -tu2 /dev/urandom | tr -d ' ') % 12000))
      if start_postmaster "$tmp" "$port"; then break; fi
      tries=$((tries + 1))
      if [ $tries -ge 10 ]; then cat "$tmp/server.log" >&2; exit 1; fi
    done
    trap - EXIT INT TERM
    printf '%s\n' "$tmp" > "$state/pgdata"
    printf 'postgresql://adit:%s@127.0.0.1:%s/postgres\n' "$password" "$port" > "$state/url"
    echo "postgres_fixture: server on 127.0.0.1:$port (pid $(head -n 1 "$tmp/data/postmaster.pid"), $tmp)" >&2
    ;;
  restart)
    tmp=$(cat "$state/pgdata")
    port=$(sed -n 's|.*@127.0.0.1:\([0-9]*\)/.*|\1|p' "$state/url")
    stop_postmaster "$tmp"
    # The port was just released: a few tries in case a listener of a parallel test took it.
    for try in 1 2 3 4 5; do
      start_postmaster "$tmp" "$port" && break
      [ $try -lt 5 ] || { cat "$tmp/server.log" >&2; exit 1; }
      sleep 1
    done
    ;;
  stop)
    if [ -f "$state/pgdata" ]; then
      stop_server "$(cat "$state/pgdata")"
    fi
    rm -f "$state/url" "$state/pgdata"
    ;;
  *) echo "usage: postgres_fixture.sh start|restart|stop STATE_DIR" >&2; exit 2 ;;
esac
