#!/usr/bin/env bash
# Load test on loopback: p50/p99 latency and throughput of POST /v1/fit (default options) for
# 1,000- and 10,000-point LineStrings at concurrency 1, 2 and 8. Bounded: a fixed number of
# requests per run (REQUESTS_1K, REQUESTS_10K), each run under `timeout`, and the server stops
# itself after 15 minutes. Needs `hey` (Debian: apt-get install hey) and python3.
# Prints a Markdown table.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
cd "$ROOT"
PORT="${SPHEREFIT_LOAD_PORT:-18094}"
REQUESTS_1K="${REQUESTS_1K:-400}"
REQUESTS_10K="${REQUESTS_10K:-104}"
if ! command -v hey >/dev/null; then
  echo "installing hey" >&2
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq hey >/dev/null
fi
cargo build --release --quiet
WORK="$(mktemp -d)"

python3 - "$WORK" <<'PY'
import json, math, random, sys
random.seed(7)
for n in (1000, 10000):
    coords = []
    for i in range(n):
        u = i / (n - 1)
        # A wavy 2,000 km track with GPS-like noise of about 5 m.
        lon = -100 + 20 * u + 0.3 * math.sin(40 * u) + random.gauss(0, 0.00005)
        lat = 30 + 3 * math.sin(6 * u) + random.gauss(0, 0.00005)
        coords.append([round(lon, 7), round(lat, 7)])
    doc = {"type": "Feature", "properties": {"points": n},
           "geometry": {"type": "LineString", "coordinates": coords}}
    json.dump(doc, open(f"{sys.argv[1]}/line{n}.geojson", "w"))
PY

"$ROOT/target/release/spherefit" serve --addr "127.0.0.1:$PORT" --exit-after-s 900 \
  --log-format json 2>"$WORK/server.log" &
PID=$!
cleanup() { kill "$PID" 2>/dev/null || true; wait "$PID" 2>/dev/null || true; rm -rf "$WORK"; }
trap cleanup EXIT
for _ in $(seq 1 100); do
  curl -fsS "http://127.0.0.1:$PORT/health" >/dev/null 2>&1 && break
  sleep 0.1
done

URL="http://127.0.0.1:$PORT/v1/fit"
echo "machine: $(nproc) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
echo "server: spherefit serve (release), default options (fit_concurrency = $(nproc))"
echo
echo "| points per request | concurrency | requests | p50 (ms) | p99 (ms) | requests/s | points/s |"
echo "|---:|---:|---:|---:|---:|---:|---:|"
for n in 1000 10000; do
  body="$WORK/line$n.geojson"
  requests=$REQUESTS_1K
  [ "$n" = 10000 ] && requests=$REQUESTS_10K
  # Warm up, and check that the request succeeds.
  code=$(curl -s -o /dev/null -w '%{http_code}' -H 'Content-Type: application/geo+json' --data-binary @"$body" "$URL")
  [ "$code" = 200 ] || { echo "warm-up request got $code" >&2; exit 1; }
  for c in 1 2 8; do
    out="$WORK/hey-$n-$c.csv"
    # hey sends requests/concurrency per worker; keep requests a multiple of 8.
    t0=$(date +%s.%N)
    timeout 300 hey -n "$requests" -c "$c" -m POST -T application/geo+json -D "$body" -o csv "$URL" > "$out"
    t1=$(date +%s.%N)
    python3 - "$out" "$n" "$c" "$requests" "$t0" "$t1" <<'PY'
import csv, sys
path, n, c, requests, t0, t1 = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), float(sys.argv[5]), float(sys.argv[6])
rows = list(csv.DictReader(open(path)))
codes = {}
for r in rows:
    codes[r["status-code"]] = codes.get(r["status-code"], 0) + 1
if codes != {"200": requests}:
    sys.exit(f"not every request succeeded: {codes}")
lat = sorted(float(r["response-time"]) * 1000 for r in rows)
def pct(p):
    # Nearest-rank percentile.
    k = max(1, -(-p * len(lat) // 100))
    return lat[int(k) - 1]
rps = len(lat) / (t1 - t0)
print(f"| {n:,} | {c} | {len(lat)} | {pct(50):.1f} | {pct(99):.1f} | {rps:.1f} | {rps * n:,.0f} |")
PY
  done
done
echo
echo "command: scripts/load.sh (REQUESTS_1K=$REQUESTS_1K REQUESTS_10K=$REQUESTS_10K)"
