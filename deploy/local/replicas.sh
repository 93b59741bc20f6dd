#!/usr/bin/env bash
# deploy/service.yaml on one machine: PostgreSQL 15 (a throwaway cluster), two `spherefit
# serve` replicas sharing it as their job store, and haproxy in front, round-robin (each request
# to the other replica), all on 127.0.0.1. What CI runs (.ci/replicas.sh) is this script.
#
#   deploy/local/replicas.sh up DIR                  # start everything; returns once all answer
#   deploy/local/replicas.sh replica DIR a|b start|stop|kill    # kill = kill -9
#   deploy/local/replicas.sh postgres DIR start|stop
#   deploy/local/replicas.sh proxy DIR drain|ready a|b   # haproxy's runtime API: send no new
#                                                    # requests to a replica / send them again
#   deploy/local/replicas.sh down DIR                # stop everything (DIR is kept: logs)
#
# DIR (made if missing) holds the cluster, the logs (a.log, b.log: JSON lines; haproxy.log;
# pg/postgres.log) and the settings of the run (env). Settings, from the environment at `up`:
#   SPHEREFIT_BIN      the binary (target/release/spherefit)
#   PROXY_PORT         the proxy, the one address clients use (18180)
#   REPLICA_PORTS      the two replicas ("18181 18182")
#   PG_PORT            PostgreSQL (55480)
#   LIFETIME_S         every process stops itself this long after `up` (900)
#   SPHEREFIT_API_KEYS_FILE   OWNER:SHA256_HEX lines; unset, the service is open (loopback)
#   SERVE_ARGS         more `spherefit serve` flags for both replicas
# Responses through the proxy carry `X-Spherefit-Replica: a` or `b` (the replica that answered).
# The proxy also turns `Authorization: Basic base64(OWNER:TOKEN)` into `Bearer TOKEN`, for
# clients that can only send Basic (QGIS 3.22's authentication configurations).
# Run as root (PostgreSQL then runs as the postgres user, through runuser) or as a user who can
# run initdb; needs Debian's postgresql (15) and haproxy.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/../.." && pwd)"
PG_BIN="${PG_BIN:-/usr/lib/postgresql/15/bin}"

usage() { sed -n '2,26p' "$0" >&2; exit 2; }
[ $# -ge 2 ] || usage
cmd="$1"; DIR="$2"; shift 2
mkdir -p "$DIR"
DIR="$(cd "$DIR" && pwd)"

as_postgres() {
  if [ "$(id -u)" -eq 0 ]; then runuser -u postgres -- "$@"; else "$@"; fi
}

if [ "$cmd" = up ]; then
  lifetime="${LIFETIME_S:-900}"
  cat >"$DIR/env" <<EOF
SPHEREFIT_BIN='${SPHEREFIT_BIN:-$ROOT/target/release/spherefit}'
PROXY_PORT='${PROXY_PORT:-18180}'
REPLICA_PORTS='${REPLICA_PORTS:-18181 18182}'
PG_PORT='${PG_PORT:-55480}'
DEADLINE='$(( $(date +%s) + lifetime ))'
API_KEYS='${SPHEREFIT_API_KEYS_FILE:-}'
SERVE_ARGS='${SERVE_ARGS:-}'
EOF
fi
[ -f "$DIR/env" ] || { echo "replicas.sh: $DIR/env missing: run 'up' first" >&2; exit 2; }
# shellcheck disable=SC1091
. "$DIR/env"
read -r PORT_A PORT_B <<<"$REPLICA_PORTS"
remaining() { local r=$(( DEADLINE - $(date +%s) )); [ "$r" -gt 0 ] || r=1; echo "$r"; }
STORE="postgres://postgres@127.0.0.1:$PG_PORT/spherefit"

wait_http() { # URL SECONDS
  local i
  for i in $(seq 1 $(( $2 * 10 ))); do
    curl -fsS -o /dev/null "$1" 2>/dev/null && return 0
    sleep 0.1
  done
  echo "replicas.sh: $1 did not answer within $2 s" >&2
  return 1
}

postgres() {
  local pg="$DIR/pg"
  case "$1" in
    start)
      if [ ! -d "$pg/data" ]; then
        mkdir -p "$pg"
        chmod 755 "$DIR"
        [ "$(id -u)" -ne 0 ] || chown postgres "$pg"
        as_postgres "$PG_BIN/initdb" -D "$pg/data" -A trust -U postgres >"$pg/initdb.log"
      fi
      as_postgres "$PG_BIN/pg_ctl" -D "$pg/data" -l "$pg/postgres.log" -w -t 30 \
        -o "-p $PG_PORT -k $pg -c listen_addresses=127.0.0.1" start >/dev/null
      psql -h 127.0.0.1 -p "$PG_PORT" -U postgres -tAc "select 1 from pg_database where datname = 'spherefit'" \
        | grep -q 1 || psql -h 127.0.0.1 -p "$PG_PORT" -U postgres -qc 'create database spherefit'
      # The cluster stops itself at the deadline, whoever started it.
      if [ ! -f "$pg/watchdog.pid" ] || ! kill -0 "$(cat "$pg/watchdog.pid")" 2>/dev/null; then
        setsid bash -c "sleep $(remaining); $(declare -f as_postgres); as_postgres '$PG_BIN/pg_ctl' -D '$pg/data' -m immediate stop" \
          >/dev/null 2>&1 </dev/null &
        echo $! >"$pg/watchdog.pid"
      fi
      ;;
    stop)
      as_postgres "$PG_BIN/pg_ctl" -D "$pg/data" -m fast -w -t 30 stop >/dev/null
      ;;
    *) usage ;;
  esac
}

replica() { # a|b start|stop|kill
  local name="$1" port pidf="$DIR/$1.pid"
  case "$name" in a) port="$PORT_A" ;; b) port="$PORT_B" ;; *) usage ;; esac
  case "$2" in
    start)
      local keys=()
      [ -z "$API_KEYS" ] || keys=(--api-keys "$API_KEYS")
      # shellcheck disable=SC2086
      setsid "$SPHEREFIT_BIN" serve --addr "127.0.0.1:$port" --job-store "$STORE" "${keys[@]}" \
        --exit-after-s "$(remaining)" --log-format json $SERVE_ARGS >>"$DIR/$name.log" 2>&1 </dev/null &
      echo $! >"$pidf"
      wait_http "http://127.0.0.1:$port/health" 30
      # With the proxy running, return once its health check has the replica back in rotation.
      if [ -S "$DIR/haproxy.sock" ] && [ -f "$DIR/haproxy.pid" ]; then
        for _ in $(seq 1 100); do
          proxy_api "show stat" | grep -q "^replicas,$name,.*,UP," && return 0
          sleep 0.1
        done
        echo "replicas.sh: the proxy did not take replica $name back within 10 s" >&2
        return 1
      fi
      ;;
    stop|kill)
      [ -f "$pidf" ] || return 0
      local pid sig=TERM
      pid="$(cat "$pidf")"
      [ "$2" = stop ] || sig=KILL
      kill -s "$sig" "$pid" 2>/dev/null || true
      for _ in $(seq 1 600); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
      rm -f "$pidf"
      ;;
    *) usage ;;
  esac
}

proxy_api() { # a runtime API command for haproxy's stats socket
  python3 -c 'import socket,sys
s=socket.socket(socket.AF_UNIX); s.connect(sys.argv[1]); s.sendall(sys.argv[2].encode()+b"\n")
out=b""
while True:
    b=s.recv(4096)
    if not b: break
    out+=b
sys.stdout.write(out.decode())' "$DIR/haproxy.sock" "$1"
}

proxy() {
  case "$1" in
    start)
      cat >"$DIR/haproxy.cfg" <<EOF
global
  maxconn 512
  stats socket $DIR/haproxy.sock mode 600 level admin
defaults
  mode http
  log stdout format raw local0
  option httplog
  timeout connect 2s
  timeout client 120s
  timeout server 120s
  # A replica that is down (killed, restarting): the request is tried on the other one.
  retries 2
  option redispatch 1
frontend spherefit
  bind 127.0.0.1:$PROXY_PORT
  default_backend replicas
  # QGIS 3.22's authentication configurations cannot send a bearer token (its "API Header"
  # method came later); its "Basic" method can carry one: user name the owner, password the
  # token. Rewritten here to the header "Authorization: Bearer TOKEN" the service reads.
  http-request set-var(txn.basic) req.hdr(authorization),bytes(6),b64dec if { req.hdr(authorization) -m beg "Basic " }
  http-request set-header Authorization "Bearer %[var(txn.basic),field(2,:)]" if { var(txn.basic) -m found }
  # Which replica answered (the checks read it; harmless for clients).
  http-response set-header X-Spherefit-Replica %[srv_name]
backend replicas
  # Each request to the other replica; no stickiness: any replica serves any job.
  balance roundrobin
  option httpchk GET /health
  http-check expect status 200
  default-server inter 1s fall 2 rise 1
  server a 127.0.0.1:$PORT_A check
  server b 127.0.0.1:$PORT_B check
EOF
      haproxy -c -q -f "$DIR/haproxy.cfg"
      setsid timeout "$(remaining)" haproxy -db -f "$DIR/haproxy.cfg" >>"$DIR/haproxy.log" 2>&1 </dev/null &
      echo $! >"$DIR/haproxy.pid"
      wait_http "http://127.0.0.1:$PROXY_PORT/health" 10
      ;;
    stop)
      [ -f "$DIR/haproxy.pid" ] || return 0
      kill "$(cat "$DIR/haproxy.pid")" 2>/dev/null || true
      rm -f "$DIR/haproxy.pid"
      ;;
    drain|ready)
      case "${2:-}" in a|b) ;; *) usage ;; esac
      proxy_api "set server replicas/$2 state $1" >/dev/null
      ;;
    *) usage ;;
  esac
}

case "$cmd" in
  up)
    postgres start
    replica a start
    replica b start
    proxy start
    echo "proxy http://127.0.0.1:$PROXY_PORT/ -> replicas a 127.0.0.1:$PORT_A, b 127.0.0.1:$PORT_B;" \
      "job store $STORE; everything stops itself in $(remaining) s; logs in $DIR"
    ;;
  replica) [ $# -eq 2 ] || usage; replica "$1" "$2" ;;
  postgres) [ $# -eq 1 ] || usage; postgres "$1" ;;
  proxy) [ $# -ge 1 ] || usage; proxy "$@" ;;
  down)
    proxy stop
    replica a stop
    replica b stop
    if [ -d "$DIR/pg/data" ] && [ -f "$DIR/pg/data/postmaster.pid" ]; then postgres stop || true; fi
    if [ -f "$DIR/pg/watchdog.pid" ]; then kill -- "-$(cat "$DIR/pg/watchdog.pid")" 2>/dev/null || true; fi
    ;;
  *) usage ;;
esac
