#!/usr/bin/env bash
# The numbers of docs/ogc.md, "Replicas, measured": jobs per second through one replica and
# through two (the world-atlas 50m countries at 5 km, N jobs), and the latency a job store in
# PostgreSQL adds to a job against the disk store (one job at a time, polled every 5 ms).
# The topology is deploy/local/replicas.sh (PostgreSQL 15, two replicas, round-robin haproxy);
# "one replica" is the same with replica b stopped. Run as root (PostgreSQL runs as postgres).
#
#   scripts/ogc/replicas_bench.sh            # N=100 jobs, LATENCY_N=30
#   N=20 LATENCY_N=10 scripts/ogc/replicas_bench.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
N="${N:-100}"
LATENCY_N="${LATENCY_N:-30}"
DISK_PORT="${DISK_PORT:-18189}"
cargo build --release --quiet --bin spherefit
[ -x scripts/coverage/node_modules/.bin/mapshaper ] || npm ci --silent --no-audit --no-fund --prefix scripts/coverage >/dev/null

RUN="$(mktemp -d /var/tmp/spherefit-replicas-bench.XXXXXX)"
L=deploy/local/replicas.sh
DISK_PID=""
cleanup() {
  [ -z "$DISK_PID" ] || kill "$DISK_PID" 2>/dev/null || true
  "$L" down "$RUN" >/dev/null 2>&1 || true
  rm -rf "$RUN"
}
trap cleanup EXIT
node scripts/coverage/topojson_read.mjs world-atlas countries-50m "$RUN/countries50m.geojson" >/dev/null
request() { # IN TOLERANCE_M OUT
  python3 -c 'import json,sys; print(json.dumps({"inputs": {"data": json.load(open(sys.argv[1])), "tolerance_m": float(sys.argv[2])}}, separators=(",", ":")))' "$1" "$2" >"$3"
}
request "$RUN/countries50m.geojson" 5000 "$RUN/c50m.json"
request fixtures/coverage_us_states.geojson 1000 "$RUN/states.json"
echo "inputs: world-atlas 50m countries at 5 km ($(wc -c <"$RUN/c50m.json") bytes a request);" \
  "US states coverage at 1 km ($(wc -c <"$RUN/states.json") bytes)"
echo "machine: $(nproc) CPUs; $(git rev-parse --short HEAD)"

export PROXY_PORT="${PROXY_PORT:-18180}" LIFETIME_S=3600
# Room for N unfinished jobs of one owner (the default 4 would answer 429 and the bench would wait).
export SERVE_ARGS="--max-jobs $(( N + 8 )) --max-owner-jobs $(( N + 8 ))"
URL="http://127.0.0.1:$PROXY_PORT/"
"$L" up "$RUN" >/dev/null

echo "== $N jobs through one replica (b stopped), then through two"
"$L" replica "$RUN" b stop
sleep 3   # haproxy's health check marks b down (fall 2, inter 1 s)
python3 scripts/ogc/jobs_bench.py throughput "$URL" "$RUN/c50m.json" "$N" | sed 's/^/one replica: /'
"$L" replica "$RUN" b start
sleep 2
python3 scripts/ogc/jobs_bench.py throughput "$URL" "$RUN/c50m.json" "$N" | sed 's/^/two replicas: /'

echo "== latency of one job at a time: PostgreSQL store (through the proxy) against the disk store"
for input in states c50m; do
  python3 scripts/ogc/jobs_bench.py latency "$URL" "$RUN/$input.json" "$LATENCY_N" | sed "s/^/postgres, $input: /"
done
target/release/spherefit serve --addr "127.0.0.1:$DISK_PORT" --data-dir "$RUN/disk" \
  --exit-after-s 1800 --log-format json 2>>"$RUN/disk.log" &
DISK_PID=$!
for _ in $(seq 100); do curl -fsS "http://127.0.0.1:$DISK_PORT/health" >/dev/null 2>&1 && break; sleep 0.1; done
for input in states c50m; do
  python3 scripts/ogc/jobs_bench.py latency "http://127.0.0.1:$DISK_PORT/" "$RUN/$input.json" "$LATENCY_N" | sed "s/^/disk, $input: /"
done
