#!/usr/bin/env bash
# Real OGC API clients against the release server on loopback (issue #27): OWSLib (PyPI) lists
# the processes and runs `fit` synchronously and as a job (scripts/ogc/owslib_check.py); GDAL's
# ogrinfo (Debian gdal-bin) opens the finished job through the OAPIF driver and must list every
# feature with its properties; so does QGIS 3.22 (Debian qgis + python3-qgis, headless;
# scripts/ogc/qgis_check.py), which also renders it; the job survives a restart of the service.
# Self-contained and bounded in time (each server stops itself after 120 s). Called from .ci/run.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
cd "$ROOT"
export CARGO_TERM_COLOR=never
PORT="${SPHEREFIT_OGC_PORT:-18094}"
URL="http://127.0.0.1:$PORT"

venv=target/ogc-venv
if [ ! -x "$venv/bin/python" ] || ! "$venv/bin/python" -c 'import owslib' 2>/dev/null; then
  bash .ci/prefetch.sh ogc-venv
fi
if ! command -v ogrinfo >/dev/null 2>&1 || ! /usr/bin/python3 -c 'import qgis.core' 2>/dev/null; then
  bash .ci/prefetch.sh debian
fi
echo "== cargo build --release"
cargo build --release --quiet

WORK="$(mktemp -d)"
PID=""
start_server() {
  "$ROOT/target/release/spherefit" serve --addr "127.0.0.1:$PORT" --exit-after-s 120 \
    --data-dir "$WORK/data" --log-format json 2>>"$WORK/server.log" &
  PID=$!
  for _ in $(seq 1 100); do
    curl -fsS "$URL/health" >/dev/null 2>&1 && return 0
    sleep 0.1
  done
  curl -fsS "$URL/health" >/dev/null
}
stop_server() {
  [ -n "$PID" ] || return 0
  kill "$PID" 2>/dev/null || true
  wait "$PID" 2>/dev/null || true
  PID=""
}
cleanup() {
  status=$?
  stop_server
  [ "$status" -eq 0 ] || { echo "== last server log lines:"; tail -n 5 "$WORK/server.log" || true; }
  rm -rf "$WORK"
}
trap cleanup EXIT

start_server
INPUT="$ROOT/fixtures/coverage_us_states.geojson"
echo "== OWSLib against $URL ($INPUT)"
timeout 180 "$venv/bin/python" scripts/ogc/owslib_check.py "$URL/" "$INPUT" | tee "$WORK/owslib.out"
JOB="$(tail -n 1 "$WORK/owslib.out")"
want=$(python3 -c 'import json,sys; print(len(json.load(open(sys.argv[1]))["features"]))' "$INPUT")

check_ogrinfo() {
  echo "== ogrinfo OAPIF:$URL/ $JOB ($1)"
  timeout 60 ogrinfo -ro -al -q "OAPIF:$URL/" "$JOB" >"$WORK/ogrinfo.txt"
  local n props names
  n=$(grep -c '^OGRFeature(' "$WORK/ogrinfo.txt" || true)
  # The input's own property (each state's name) comes through too.
  names=$(grep -c '^  name (String) = ' "$WORK/ogrinfo.txt" || true)
  # Every feature with its properties: the fit report of each (GDAL lists it as a JSON field).
  props=$(grep -cF '  fit (String(JSON)) = {' "$WORK/ogrinfo.txt" || true)
  echo "ogrinfo: $n features, $props with properties.fit, $names with properties.name (want $want)"
  [ "$n" = "$want" ] && [ "$props" = "$want" ] && [ "$names" = "$want" ]
}
check_ogrinfo "before a restart"
timeout 60 ogrinfo -ro -so "OAPIF:$URL/" | grep -q "$JOB"

echo "== QGIS 3.22 (PyQGIS, headless): the job as an OAPIF layer, every feature, a PNG"
QT_QPA_PLATFORM=offscreen timeout 300 /usr/bin/python3 scripts/ogc/qgis_check.py "$URL/" "$JOB" "$WORK/qgis.png"

echo "== restart: the finished job stays readable"
stop_server
start_server
curl -fsS "$URL/jobs/$JOB" | python3 -c 'import json,sys; s=json.load(sys.stdin); assert s["status"]=="successful", s'
check_ogrinfo "after a restart"
echo "== OGC clients done"
