#!/usr/bin/env bash
# The 10m land outlines (4,037 rings, 408,884 points; scripts/speed_bench.sh prepares them) as an
# OGC API - Processes job at 100 m: submitted async, its progress polled, the service restarted
# once the job is finished, the result read back and compared with `spherefit fit`'s.
#   PREPARE_ONLY=1 scripts/speed_bench.sh && scripts/ogc/land_job.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
PORT="${PORT:-18096}"
URL="http://127.0.0.1:$PORT"
IN=target/speed-bench/land10m_rings.geojson
WORK="$(mktemp -d)"
PID=""
start() {
  target/release/spherefit serve --addr "127.0.0.1:$PORT" --data-dir "$WORK/data" --exit-after-s 900 \
    --log-format json 2>>"$WORK/server.log" &
  PID=$!
  for _ in $(seq 100); do curl -fsS "$URL/health" >/dev/null 2>&1 && return 0; sleep 0.1; done
}
stop() { kill "$PID" 2>/dev/null || true; wait "$PID" 2>/dev/null || true; }
trap 'stop; rm -rf "$WORK"' EXIT
cargo build --release --quiet --bin spherefit
start
python3 -c 'import json,sys; print(json.dumps({"inputs": {"data": json.load(open(sys.argv[1])), "tolerance_m": 100}}, separators=(",", ":")))' "$IN" >"$WORK/req.json"
t0=$(date +%s.%N)
job=$(curl -fsS -H 'Prefer: respond-async' -H 'Content-Type: application/json' --data-binary @"$WORK/req.json" \
  "$URL/processes/fit/execution" | python3 -c 'import json,sys; print(json.load(sys.stdin)["jobID"])')
echo "job $job submitted"
while :; do
  s=$(curl -fsS "$URL/jobs/$job")
  st=$(echo "$s" | python3 -c 'import json,sys; s=json.load(sys.stdin); print(s["status"], s["progress"])')
  echo "$(python3 -c "import time; print(round(time.time() - $t0, 1))") s: $st"
  case "$st" in successful*|failed*|dismissed*) break;; esac
  sleep 1
done
echo "$st" | grep -q successful
echo "restart"
stop; start
curl -fsS "$URL/jobs/$job" | python3 -c 'import json,sys; s=json.load(sys.stdin); assert s["status"] == "successful", s; print("after restart:", s["status"])'
curl -fsS -o "$WORK/job.geojson" "$URL/jobs/$job/results"
t1=$(date +%s.%N)
target/release/spherefit fit --tolerance-m 100 -o "$WORK/cli.geojson" "$IN"
echo "cli fit took $(python3 -c "import time; print(round(time.time() - $t1, 1))") s"
python3 - "$WORK/job.geojson" "$WORK/cli.geojson" <<'PY'
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
n = sum(len(f["geometry"]["coordinates"]) for f in a["features"])
print(f"job result: {len(a['features'])} features, {n} output points; equal to spherefit fit's: {a == b}")
sys.exit(0 if a == b else 1)
PY
