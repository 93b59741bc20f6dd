#!/usr/bin/env bash
# End-to-end test of the map page (GET /): Debian's Chromium, headless, driven by npm
# playwright-core, against the release server on loopback. Also the unit tests of the page's
# globe module (node's test runner). Self-contained and bounded in time: the server stops
# itself after 240 s, the tests have 180 s. Called from .ci/run. Screenshots:
# target/browser/*.png (CI artefacts).
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
cd "$ROOT"
export CARGO_TERM_COLOR=never
PORT="${SPHEREFIT_BROWSER_PORT:-18091}"
SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"

if [ ! -x /usr/bin/chromium ]; then
  echo "== apt-get install chromium"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends chromium >/dev/null
fi
if ! command -v node >/dev/null 2>&1; then
  echo "== apt-get install nodejs npm"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends nodejs npm >/dev/null
fi
if [ -z "${SPHEREFIT_CI_PREFETCHED:-}" ]; then
  echo "== npm ci (tests/browser: playwright-core, topojson-client, world-atlas)"
  npm ci --prefix tests/browser --no-audit --no-fund --loglevel=error
fi

echo "== the basemap is what scripts/land_geojson.mjs makes"
WORK="$(mktemp -d)"
PID=""
cleanup() {
  if [ -n "$PID" ]; then
    kill "$PID" 2>/dev/null || true
    wait "$PID" 2>/dev/null || true
  fi
  rm -rf "$WORK"
}
trap cleanup EXIT
node scripts/land_geojson.mjs "$WORK/land.geojson" >/dev/null
if ! cmp -s web/land-110m.geojson "$WORK/land.geojson"; then
  echo "web/land-110m.geojson differs from what scripts/land_geojson.mjs makes" >&2
  exit 1
fi

echo "== cargo build --release"
cargo build --release --quiet

LOG="$WORK/server.log"
echo "== spherefit serve on 127.0.0.1:$PORT (log: $LOG)"
"$ROOT/target/release/spherefit" serve --addr "127.0.0.1:$PORT" --exit-after-s 240 \
  --max-body-bytes 1048576 --max-points 20000 2>"$LOG" &
PID=$!
for _ in $(seq 1 100); do
  if curl -fsS "http://127.0.0.1:$PORT/health" >/dev/null 2>&1; then break; fi
  sleep 0.1
done
curl -fsS "http://127.0.0.1:$PORT/health" >/dev/null

mkdir -p target/browser
rm -f target/browser/*.png
echo "== node --test (globe unit tests, map page end to end)"
status=0
SPHEREFIT_URL="http://127.0.0.1:$PORT" SPHEREFIT_SHOTS="$ROOT/target/browser" \
  timeout 180 node --test --test-concurrency=1 --test-reporter=spec \
  tests/browser/globe.test.mjs tests/browser/map_page.test.mjs || status=$?
if [ "$status" -ne 0 ]; then
  echo "== browser tests failed ($status); last server log lines:"
  tail -n 5 "$LOG" || true
  exit "$status"
fi
shots=$(ls target/browser/*.png | wc -l)
echo "== $shots screenshots in target/browser/"
[ "$shots" -ge 9 ]
