#!/usr/bin/env bash
# The replicated deployment as a user runs it (issue #54): deploy/local/replicas.sh starts
# PostgreSQL 15, two `spherefit serve` replicas sharing it as their job store and a round-robin
# haproxy in front, with two owners' keys; then, through the proxy only:
#   1. no token: 401 with WWW-Authenticate: Bearer; a wrong one: 401;
#   2. OWSLib (its `headers` carry the token) runs `fit` as a job; the replica that took the POST
#      is drained from the proxy and every poll is answered by the other (scripts/ogc/replicas_owslib.py);
#   3. GDAL (`GDAL_HTTP_HEADERS`) and QGIS 3.22 (a "Basic" authentication configuration: owner and
#      token; scripts/ogc/qgis_check.py) open the result as an OGC API - Features layer, every
#      feature and property; QGIS renders it to a PNG;
#   4. a second owner sees none of the first's jobs: empty /jobs and /collections, 404 for the
#      job, its results, its collection and DELETE;
#   5. a ~30 s job: the replica running it is killed (kill -9); the other finishes it;
#   6. both replicas restarted: every finished result is still served, byte for byte;
#   7. PostgreSQL stopped: 503 problem+json (store-unavailable) from the replicas, not a hang;
#      started again: the service recovers.
# Called from .ci/run after the OGC step; runs on its own too (as root). Bounded in time: every
# process of the topology stops itself after LIFETIME_S, and each client call has a timeout.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
cd "$ROOT"
export CARGO_TERM_COLOR=never
start=$(date +%s)
step() { echo; echo "== [replicas $(( $(date +%s) - start ))s] $*"; }

bash .ci/prefetch.sh debian
venv=target/ogc-venv
if [ ! -x "$venv/bin/python" ] || ! "$venv/bin/python" -c 'import owslib' 2>/dev/null; then
  bash .ci/prefetch.sh ogc-venv
fi
cargo build --release --quiet --bin spherefit

RUN="$(mktemp -d /var/tmp/spherefit-replicas.XXXXXX)"
L="$ROOT/deploy/local/replicas.sh"
export PROXY_PORT="${PROXY_PORT:-18180}" LIFETIME_S="${LIFETIME_S:-900}"
# A lease of 5 s rather than the default 30 s: a killed replica's job is taken up sooner, so the
# check takes less time (the mechanism is the same).
export SERVE_ARGS="--job-lease-s 5 ${SERVE_ARGS:-}"
URL="http://127.0.0.1:$PROXY_PORT"
cleanup() {
  status=$?
  "$L" down "$RUN" >/dev/null 2>&1 || true
  if [ "$status" -ne 0 ]; then
    for f in a.log b.log haproxy.log pg/postgres.log; do
      echo "== last lines of $f:"; tail -n 8 "$RUN/$f" 2>/dev/null || true
    done
  fi
  rm -rf "$RUN"
}
trap cleanup EXIT

# Two owners; the key file holds only the tokens' SHA-256 digests.
ALICE="$(head -c 24 /dev/urandom | od -An -tx1 | tr -d ' \n')"
BOB="$(head -c 24 /dev/urandom | od -An -tx1 | tr -d ' \n')"
{
  echo "# owner:sha256(token)"
  echo "alice:$(printf %s "$ALICE" | sha256sum | cut -d' ' -f1)"
  echo "bob:$(printf %s "$BOB" | sha256sum | cut -d' ' -f1)"
} >"$RUN/api-keys"
export SPHEREFIT_API_KEYS_FILE="$RUN/api-keys"

step "deploy/local/replicas.sh up"
"$L" up "$RUN"

# curl through the proxy: CODE BODY-FILE HEADERS-FILE for METHOD PATH [TOKEN]
call() {
  local method="$1" path="$2" token="${3:-}" auth=()
  [ -z "$token" ] || auth=(-H "Authorization: Bearer $token")
  curl -sS -m 30 -X "$method" -o "$RUN/body" -D "$RUN/headers" -w '%{http_code}' \
    -H 'Accept: application/json' "${auth[@]}" "$URL$path"
}
header() { grep -i "^$1:" "$RUN/headers" | head -1 | cut -d' ' -f2- | tr -d '\r'; }
problem_type() { python3 -c 'import json,sys; print(json.load(open(sys.argv[1])).get("type",""))' "$RUN/body"; }

step "no token: 401 with WWW-Authenticate; a wrong token: 401"
code=$(call GET /jobs)
echo "GET /jobs without a token: $code, WWW-Authenticate: $(header www-authenticate)"
[ "$code" = 401 ] && header www-authenticate | grep -q '^Bearer'
code=$(call GET /collections "not-$ALICE")
echo "GET /collections with a wrong token: $code"
[ "$code" = 401 ]
code=$(call GET /health)
[ "$code" = 200 ]

step "OWSLib: fit as a job through the proxy; every poll on the replica that did not take the POST"
# The 110m world with the default fit: about 1 s of work, so the job is polled several times.
timeout 300 "$venv/bin/python" scripts/ogc/replicas_owslib.py "$URL/" "$ROOT/fixtures/coverage_world_110m.geojson" \
  "$ALICE" "$L" "$RUN" | tee "$RUN/owslib.out"
OWSJOB="$(tail -n 1 "$RUN/owslib.out")"

# The job GDAL and QGIS open: the US states at 1 km (every input polygon valid, so QGIS can ask
# every output polygon to be valid too).
INPUT="$ROOT/fixtures/coverage_us_states.geojson"
python3 -c 'import json,sys; print(json.dumps({"inputs": {"data": json.load(open(sys.argv[1])), "tolerance_m": 1000}}))' \
  "$INPUT" >"$RUN/states.json"
JOB=$(curl -fsS -m 60 -H "Authorization: Bearer $ALICE" -H 'Prefer: respond-async' \
  -H 'Content-Type: application/json' --data-binary @"$RUN/states.json" "$URL/processes/fit/execution" \
  | python3 -c 'import json,sys; print(json.load(sys.stdin)["jobID"])')
for _ in $(seq 1 600); do
  st=$(curl -fsS -m 10 -H "Authorization: Bearer $ALICE" "$URL/jobs/$JOB" | python3 -c 'import json,sys; print(json.load(sys.stdin)["status"])')
  case "$st" in accepted|running) sleep 0.1 ;; *) break ;; esac
done
echo "job $JOB (US states at 1 km): $st"
[ "$st" = successful ]
want=$(python3 -c 'import json,sys; print(len(json.load(open(sys.argv[1]))["features"]))' "$INPUT")

step "GDAL: ogrinfo OAPIF: through the proxy, the token in GDAL_HTTP_HEADERS"
GDAL_HTTP_HEADERS="Authorization: Bearer $ALICE" timeout 120 ogrinfo -ro -al -q "OAPIF:$URL/" "$JOB" >"$RUN/ogrinfo.txt"
n=$(grep -c '^OGRFeature(' "$RUN/ogrinfo.txt" || true)
names=$(grep -c '^  name (String) = ' "$RUN/ogrinfo.txt" || true)
fits=$(grep -cF '  fit (String(JSON)) = {' "$RUN/ogrinfo.txt" || true)
echo "ogrinfo: $n features, $fits with properties.fit, $names with properties.name (want $want)"
[ "$n" = "$want" ] && [ "$fits" = "$want" ] && [ "$names" = "$want" ]
set +e
timeout 60 ogrinfo -ro -so "OAPIF:$URL/" >"$RUN/ogrinfo-anon.txt" 2>&1
set -e
grep -q 'HTTP error code : 401' "$RUN/ogrinfo-anon.txt" && echo "ogrinfo without the token: HTTP 401"

step "QGIS 3.22: the result as an OAPIF layer through the proxy, the token in an authentication configuration"
QT_QPA_PLATFORM=offscreen timeout 300 /usr/bin/python3 scripts/ogc/qgis_check.py "$URL/" "$JOB" \
  "$RUN/qgis.png" --owner alice --token "$ALICE"
if [ -n "${SPHEREFIT_CI_ARTIFACTS:-}" ]; then cp "$RUN/qgis.png" "$SPHEREFIT_CI_ARTIFACTS/replicas-qgis.png"; fi

step "a second owner sees none of the first's jobs"
for path in /jobs /collections; do
  code=$(call GET "$path" "$BOB")
  count=$(python3 -c 'import json,sys; v=json.load(open(sys.argv[1])); print(len(v[sys.argv[2]]))' "$RUN/body" "${path#/}")
  echo "bob: GET $path: $code, $count entries"
  [ "$code" = 200 ] && [ "$count" = 0 ]
done
for req in "GET /jobs/$JOB" "GET /jobs/$JOB/results" "GET /collections/$JOB" "GET /collections/$JOB/items" "DELETE /jobs/$JOB"; do
  # shellcheck disable=SC2086
  code=$(call $req "$BOB")
  echo "bob: $req: $code $(problem_type)"
  [ "$code" = 404 ]
done
code=$(call GET "/jobs/$JOB" "$ALICE")
[ "$code" = 200 ] && echo "alice: GET /jobs/$JOB: 200 (the job is still hers, not dismissed by bob)"

step "a ~30 s job: the replica running it is killed (kill -9); the other one finishes it"
# The world-atlas 50m countries (npm, as scripts/coverage reads them), LONG_COPIES times over in
# one request (12 MB), with the default fit (no tolerance): 10 s a copy on 2 busy cores.
[ -x scripts/coverage/node_modules/.bin/mapshaper ] || npm ci --silent --no-audit --no-fund --prefix scripts/coverage >/dev/null
node scripts/coverage/topojson_read.mjs world-atlas countries-50m "$RUN/countries50m.geojson" >/dev/null
python3 - "$RUN/countries50m.geojson" "${LONG_COPIES:-3}" >"$RUN/long.json" <<'PY'
import json, sys
fc = json.load(open(sys.argv[1]))
data = {"type": "FeatureCollection", "features": fc["features"] * int(sys.argv[2])}
print(json.dumps({"inputs": {"data": data}}, separators=(",", ":")))
PY
t0=$(date +%s.%N)
LONGJOB=$(curl -fsS -m 60 -H "Authorization: Bearer $ALICE" -H 'Prefer: respond-async' \
  -H 'Content-Type: application/json' --data-binary @"$RUN/long.json" "$URL/processes/fit/execution" \
  | python3 -c 'import json,sys; print(json.load(sys.stdin)["jobID"])')
echo "job $LONGJOB posted"
status_of() {
  curl -sS -m 10 -H "Authorization: Bearer $ALICE" "$URL/jobs/$1" \
    | python3 -c 'import json,sys; s=json.load(sys.stdin); print(s.get("status"), s.get("progress"))'
}
for _ in $(seq 1 300); do
  st=$(status_of "$LONGJOB"); case "$st" in running*) break ;; esac; sleep 0.1
done
echo "status: $st"
case "$st" in running*) ;; *) echo "the job did not start running"; exit 1 ;; esac
# The replica running it is the one whose CPU time grows (the other is idle).
cpu() { awk '{print $14 + $15}' "/proc/$(cat "$RUN/$1.pid")/stat"; }
a0=$(cpu a); b0=$(cpu b); sleep 2; a1=$(cpu a); b1=$(cpu b)
if [ $(( a1 - a0 )) -gt $(( b1 - b0 )) ]; then victim=a; survivor=b; else victim=b; survivor=a; fi
echo "CPU ticks in 2 s: a $(( a1 - a0 )), b $(( b1 - b0 )): replica $victim runs the job; kill -9"
t_kill=$(date +%s.%N)
"$L" replica "$RUN" "$victim" kill
for _ in $(seq 1 1200); do
  st=$(status_of "$LONGJOB" || true); case "$st" in successful*|failed*|dismissed*) break ;; esac; sleep 0.5
done
t_done=$(date +%s.%N)
echo "status: $st"
case "$st" in successful*) ;; *) echo "the killed replica's job did not finish on replica $survivor"; exit 1 ;; esac
python3 - "$t0" "$t_kill" "$t_done" "$survivor" <<'PY'
import sys
t0, tk, td = map(float, sys.argv[1:4])
print(f"job posted at 0 s, its replica killed at {tk - t0:.1f} s, finished on replica {sys.argv[4]} "
      f"at {td - t0:.1f} s ({td - tk:.1f} s after the kill)")
PY
"$L" replica "$RUN" "$victim" start

step "both replicas restarted: every finished result still served"
sums() {
  for j in "$OWSJOB" "$JOB" "$LONGJOB"; do
    curl -fsS -m 60 -H "Authorization: Bearer $ALICE" "$URL/jobs/$j/results" | sha256sum | cut -c1-16
  done
}
before=$(sums | tr '\n' ' ')
"$L" replica "$RUN" a stop; "$L" replica "$RUN" b stop
"$L" replica "$RUN" a start; "$L" replica "$RUN" b start
after=$(sums | tr '\n' ' ')
echo "results' sha256 before: $before after: $after"
[ "$before" = "$after" ]

step "PostgreSQL stopped: 503 store-unavailable; started again: the service recovers"
"$L" postgres "$RUN" stop
t0=$(date +%s.%N)
code=$(call GET "/jobs/$JOB" "$ALICE")
echo "GET /jobs/$JOB with PostgreSQL down: $code $(problem_type), Retry-After: $(header retry-after)" \
  "($(python3 -c "import time; print(round(time.time() - $t0, 2))") s)"
[ "$code" = 503 ] && [ "$(problem_type)" = "urn:spherefit:problem:store-unavailable" ]
"$L" postgres "$RUN" start
t0=$(date +%s.%N)
for _ in $(seq 1 300); do
  code=$(call GET "/jobs/$JOB" "$ALICE"); [ "$code" = 200 ] && break; sleep 0.1
done
echo "after PostgreSQL started again: $code in $(python3 -c "import time; print(round(time.time() - $t0, 2))") s"
[ "$code" = 200 ]

step "replicated deployment checks passed"
