#!/usr/bin/env bash
# Offline base images for building the Dockerfile with podman (no Docker engine or image
# registry is reachable here; ../shared/TOOLING.md section 2), run as root:
#   1. podman, buildah, runc and debootstrap from Debian, with runc and raised default ulimits
#      in a containers.conf drop-in (crun and the default ulimits fail on these VMs);
#   2. debian:bookworm-slim: a debootstrapped minbase bookworm rootfs, imported and tagged;
#   3. rust:1.95-bookworm: that rootfs + gcc + this machine's Rust toolchain + the host CA
#      bundle (HTTPS from containers goes through the machine's TLS proxy), so cargo inside the
#      build fetches crates as it would from the real image.
# Images already present are kept; REBUILD_BASE=1 remakes them. .ci/run starts this in the
# background (.ci/prefetch.sh container-base) while it compiles; .ci/container.sh calls it too.
# This proves the Dockerfile's steps and the binary, not the real upstream images.
set -euo pipefail
WORK="${SPHEREFIT_CONTAINER_WORK:-/var/tmp/spherefit-container}"
SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"

need=()
for t in podman buildah runc debootstrap; do command -v "$t" >/dev/null || need+=("$t"); done
if [ "${#need[@]}" -gt 0 ]; then
  # The debian prefetch may hold apt's lock: wait for it rather than fail.
  $SUDO apt-get update -qq -o DPkg::Lock::Timeout=600
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq -o DPkg::Lock::Timeout=600 \
    --no-install-recommends podman buildah runc debootstrap >/dev/null
fi
$SUDO mkdir -p /etc/containers/containers.conf.d
$SUDO tee /etc/containers/containers.conf.d/50-spherefit.conf >/dev/null <<'CONF'
[containers]
default_ulimits = ["nofile=20000:20000", "nproc=4096:4096"]
[engine]
runtime = "runc"
CONF
podman --version

if [ -n "${REBUILD_BASE:-}" ] || ! podman image exists docker.io/library/debian:bookworm-slim; then
  echo "== debian:bookworm-slim from debootstrap"
  t0=$(date +%s)
  rm -rf "$WORK/rootfs"
  mkdir -p "$WORK"
  debootstrap --variant=minbase bookworm "$WORK/rootfs" http://deb.debian.org/debian >/dev/null
  tar -C "$WORK/rootfs" -c . | podman import - localhost/debian:bookworm-slim >/dev/null
  podman tag localhost/debian:bookworm-slim docker.io/library/debian:bookworm-slim
  rm -rf "$WORK/rootfs"
  echo "   $(( $(date +%s) - t0 )) s"
fi

if [ -n "${REBUILD_BASE:-}" ] || ! podman image exists docker.io/library/rust:1.95-bookworm; then
  echo "== stand-in rust:1.95-bookworm (rootfs + gcc + host toolchain + host CA bundle)"
  t0=$(date +%s)
  TOOLCHAIN="$(rustc --print sysroot)"
  ctr="$(buildah from --pull-never docker.io/library/debian:bookworm-slim)"
  buildah run "$ctr" -- sh -c 'apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends gcc libc6-dev ca-certificates >/dev/null && rm -rf /var/lib/apt/lists/*'
  for d in bin lib libexec; do
    [ -d "$TOOLCHAIN/$d" ] && buildah copy "$ctr" "$TOOLCHAIN/$d" "/usr/local/rust/$d" >/dev/null
  done
  buildah copy "$ctr" /etc/ssl/certs/ca-certificates.crt /etc/ssl/certs/ca-certificates.crt >/dev/null
  buildah config \
    --env CARGO_HOME=/usr/local/cargo \
    --env PATH=/usr/local/cargo/bin:/usr/local/rust/bin:/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
    "$ctr"
  buildah commit "$ctr" localhost/rust:1.95-bookworm >/dev/null
  buildah rm "$ctr" >/dev/null
  podman tag localhost/rust:1.95-bookworm docker.io/library/rust:1.95-bookworm
  echo "   $(( $(date +%s) - t0 )) s"
fi
echo "base images ready"
