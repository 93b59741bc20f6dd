#!/usr/bin/env bash
# The Python package (python/): a venv under target/, the abi3 wheel built with maturin into
# target/wheels (sharing target/release with the cargo build, so a warm run recompiles only
# what changed), installed, and `pytest python/tests` (which compares with the release CLI and
# runs Dask with 2 worker processes and Spark local[2]; Spark needs Java 17).
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_TERM_COLOR=never
start=$(date +%s)
say() { echo "-- [$(( $(date +%s) - start ))s] $*"; }

if ! command -v java >/dev/null 2>&1; then
  say "apt-get install openjdk-17-jre-headless (for pyspark)"
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends openjdk-17-jre-headless >/dev/null
fi

venv=target/py-venv
if [ ! -x "$venv/bin/python" ]; then
  say "python3 -m venv $venv"
  python3 -m venv "$venv"
fi
say "pip install -r python/requirements-test.txt"
"$venv/bin/pip" install -q --disable-pip-version-check -r python/requirements-test.txt

say "maturin build --release"
rm -f target/wheels/spherefit-*.whl
"$venv/bin/maturin" build --release -m python/Cargo.toml -o target/wheels --quiet
"$venv/bin/pip" install -q --disable-pip-version-check --force-reinstall --no-deps target/wheels/spherefit-*.whl
"$venv/bin/pip" check

# The tests compare with the CLI of this checkout (built by `cargo test --release` in .ci/run).
say "cargo build --release (the CLI the tests compare with)"
cargo build --release --bin spherefit --quiet

say "cargo test -p spherefit-python (the bindings' defaults are the library's)"
cargo test -p spherefit-python --release --quiet

say "stubtest and mypy (the stubs match the extension; the package type-checks)"
(cd target && py-venv/bin/python -m mypy.stubtest spherefit._native \
  && py-venv/bin/python -m mypy --ignore-missing-imports --no-incremental -p spherefit)

say "pytest python/tests"
"$venv/bin/pytest" python/tests -q -p no:cacheprovider
say "python done"
