#!/usr/bin/env bash
# Requests per second of POST /v1/fit with the 10m US–Mexico border (the README's example, the
# fixture's third feature, 966 points) under `hey -c 4 -z DURATION`: the default fit (no
# options) and the tolerance fit at 100 m, alternated in one run against one loopback server
# (issue #26). The server listens on 127.0.0.1 only and stops itself after 10 minutes.
#
#   scripts/border_load.sh            # DURATION=10s ROUNDS=2
# Needs `hey` (Debian: apt-get install hey) and python3.
set -euo pipefail
cd "$(dirname "$0")/.."
PORT="${SPHEREFIT_LOAD_PORT:-18095}"
DURATION="${DURATION:-10s}"
ROUNDS="${ROUNDS:-2}"
command -v hey >/dev/null || { echo "needs hey (apt-get install hey)" >&2; exit 2; }
cargo build --release --quiet --bin spherefit
work="$(mktemp -d)"
python3 - "$work/border.geojson" <<'PY'
import json, sys
d = json.load(open("fixtures/us_mexico_border_natural_earth.geojson"))
json.dump({"type": "FeatureCollection", "features": [d["features"][2]]}, open(sys.argv[1], "w"))
PY
timeout 600 target/release/spherefit serve --addr "127.0.0.1:$PORT" >"$work/serve.log" 2>&1 &
server=$!
trap 'kill $server 2>/dev/null || true; rm -rf "$work"' EXIT
for _ in $(seq 50); do curl -sf "http://127.0.0.1:$PORT/health" >/dev/null 2>&1 && break; sleep 0.1; done
echo "load: $(cut -d' ' -f1-3 /proc/loadavg); hey -c 4 -z $DURATION, POST /v1/fit, 10m US-Mexico border"
for round in $(seq "$ROUNDS"); do
  for query in "" "?tolerance_m=100"; do
    out=$(hey -c 4 -z "$DURATION" -m POST -T application/json -D "$work/border.geojson" \
      "http://127.0.0.1:$PORT/v1/fit$query")
    rps=$(echo "$out" | awk '/Requests\/sec/ {print $2}')
    p50=$(echo "$out" | awk '/ 50% in/ {print $3}')
    codes=$(echo "$out" | awk '/^ *\[[0-9][0-9][0-9]\][ \t]+[0-9]+ responses/ {printf "%s %s ", $1, $2}')
    printf 'round %s %-18s %8.1f requests/s, p50 %s s, status %s\n' "$round" \
      "${query:-default}" "$rps" "$p50" "$codes"
  done
done
