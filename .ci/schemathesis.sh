#!/usr/bin/env bash
# Contract test: schemathesis (`--checks all`) against the release server on loopback.
# Self-contained and bounded in time (the server stops itself after 300 s; schemathesis has a
# 240 s budget). Called from .ci/run. Exit status: schemathesis's (0 = no failure).
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
cd "$ROOT"
export CARGO_TERM_COLOR=never
PORT="${SPHEREFIT_ST_PORT:-18090}"
EXAMPLES="${SPHEREFIT_ST_EXAMPLES:-25}"

if ! command -v schemathesis >/dev/null 2>&1; then
  echo "== pip install schemathesis"
  python3 -m pip install --quiet --disable-pip-version-check 'schemathesis==4.32.5'
fi
echo "== cargo build --release"
cargo build --release --quiet

WORK="$(mktemp -d)"
LOG="$WORK/server.log"
echo "== spherefit serve on 127.0.0.1:$PORT (log: $LOG)"
"$ROOT/target/release/spherefit" serve --addr "127.0.0.1:$PORT" --exit-after-s 300 \
  --log-format json 2>"$LOG" &
PID=$!
cleanup() {
  kill "$PID" 2>/dev/null || true
  wait "$PID" 2>/dev/null || true
  rm -rf "$WORK"
}
trap cleanup EXIT

for _ in $(seq 1 100); do
  if curl -fsS "http://127.0.0.1:$PORT/health" >/dev/null 2>&1; then break; fi
  sleep 0.1
done
curl -fsS "http://127.0.0.1:$PORT/health" >/dev/null

echo "== schemathesis run openapi.yaml --checks all --max-examples $EXAMPLES"
# Run from a scratch directory: schemathesis and hypothesis write caches into the cwd.
cd "$WORK"
status=0
timeout 240 schemathesis --config-file "$ROOT/.ci/schemathesis.toml" run "$ROOT/openapi.yaml" \
  --url "http://127.0.0.1:$PORT" \
  --checks all \
  --max-examples "$EXAMPLES" \
  --seed 20261122 \
  --workers 2 \
  --request-timeout 30 || status=$?
if [ "$status" -ne 0 ]; then
  echo "== schemathesis failed ($status); last server log lines:"
  tail -n 5 "$LOG" || true
fi
exit "$status"
