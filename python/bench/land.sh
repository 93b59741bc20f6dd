#!/usr/bin/env bash
# Bench: fit the Natural Earth 10m land outlines (npm world-atlas@2.0.2 land-10m.json, decoded
# with topojson-client into 4,061 polygons, 408,953 points) in-process, with the CLI and on Dask
# with 1 and 2 workers. Needs .ci/python.sh to have run (the venv and wheel) and node + npm.
# Usage: python/bench/land.sh [--tolerance-m M] [--repeat N]
set -euo pipefail
cd "$(dirname "$0")/../.."
dir=target/bench
mkdir -p "$dir"
if [ ! -f "$dir/land-10m.geojson" ]; then
  npm install --silent --no-audit --no-fund --prefix "$dir" world-atlas@2.0.2 topojson-client@3.1.0
  node python/bench/land_geojson.mjs "$dir/node_modules" > "$dir/land-10m.geojson"
fi
cargo build --release --bin spherefit --quiet
target/py-venv/bin/python python/bench/land.py "$dir/land-10m.geojson" target/release/spherefit "$@"
