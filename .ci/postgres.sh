#!/usr/bin/env bash
# A throwaway PostgreSQL 15 cluster on 127.0.0.1 for the tests of the PostgreSQL job store
# (src/service/ogc/postgres_tests.rs) and the replicated service. Installs Debian's
# `postgresql` if it is missing. The server refuses to run as root, so it runs as the
# `postgres` user (runuser) in a fresh directory, trusting local connections only.
#
#   bash .ci/postgres.sh run COMMAND...   start, run COMMAND with SPHEREFIT_TEST_POSTGRES set,
#                                         stop (also on failure or Ctrl-C); COMMAND's status
#   eval "$(bash .ci/postgres.sh start)"  start; exports SPHEREFIT_TEST_POSTGRES (the URL of
#                                         database `spherefit`) and SPHEREFIT_TEST_POSTGRES_DIR
#   bash .ci/postgres.sh stop DIR         stop the cluster of `start` and delete DIR
#
# The port is the first free one from 55432 (SPHEREFIT_PG_PORT to choose another start).
set -euo pipefail
cd "$(dirname "$0")/.."
SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
BIN=/usr/lib/postgresql/15/bin

install() {
  [ -x "$BIN/initdb" ] && return 0
  echo "apt-get install postgresql (PostgreSQL 15)" >&2
  # Another apt-get (the prefetch) holds the lock: wait for it (at most 10 min).
  for _ in $(seq 600); do pgrep -x apt-get >/dev/null 2>&1 || break; sleep 1; done
  $SUDO apt-get update -qq >&2
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends postgresql >&2
  [ -x "$BIN/initdb" ] || { echo "PostgreSQL 15 is not at $BIN after the install" >&2; exit 1; }
}

as_postgres() {
  if [ "$(id -u)" -eq 0 ]; then runuser -u postgres -- "$@"; else "$@"; fi
}

free_port() {
  local p
  for p in $(seq "${SPHEREFIT_PG_PORT:-55432}" "$(( ${SPHEREFIT_PG_PORT:-55432} + 50 ))"); do
    if ! (exec 3<>"/dev/tcp/127.0.0.1/$p") 2>/dev/null; then echo "$p"; return 0; fi
  done
  echo "no free port from ${SPHEREFIT_PG_PORT:-55432}" >&2; return 1
}

start() {
  install
  local dir port url
  dir=$(mktemp -d /tmp/spherefit-pg.XXXXXX)
  chmod 755 "$dir"
  [ "$(id -u)" -ne 0 ] || chown postgres "$dir"
  port=$(free_port)
  as_postgres "$BIN/initdb" -D "$dir/pg" -A trust -U postgres >"$dir/initdb.log" 2>&1 \
    || { cat "$dir/initdb.log" >&2; exit 1; }
  # Only 127.0.0.1 and a socket in $dir; fsync off (a throwaway cluster: speed over safety).
  as_postgres "$BIN/pg_ctl" -D "$dir/pg" -l "$dir/log" -w -t 30 \
    -o "-p $port -k $dir -c listen_addresses=127.0.0.1 -c fsync=off -c max_connections=200" start >&2 \
    || { cat "$dir/log" >&2; exit 1; }
  psql -q -h 127.0.0.1 -p "$port" -U postgres -c 'CREATE DATABASE spherefit' >&2
  url="postgres://postgres@127.0.0.1:$port/spherefit"
  echo "PostgreSQL 15 at $url (data in $dir)" >&2
  echo "export SPHEREFIT_TEST_POSTGRES='$url' SPHEREFIT_TEST_POSTGRES_DIR='$dir'"
}

stop() {
  local dir="$1"
  [ -d "$dir/pg" ] || return 0
  as_postgres "$BIN/pg_ctl" -D "$dir/pg" -m fast -w -t 30 stop >/dev/null 2>&1 || true
  rm -rf "$dir"
}

case "${1:-}" in
  start) start ;;
  stop) stop "${2:?give the directory of start}" ;;
  run)
    shift
    env=$(start)
    eval "$env"
    trap 'stop "$SPHEREFIT_TEST_POSTGRES_DIR"' EXIT
    trap 'exit 130' INT; trap 'exit 143' TERM    # so that a signal stops the server too
    rc=0; "$@" || rc=$?
    exit "$rc"
    ;;
  *) sed -n '2,13p' "$0" >&2; exit 2 ;;
esac
