#!/usr/bin/env bash
# The compression bench of issue 7: numbers stored by fit_to_tolerance and by a spherical
# Douglas–Peucker at the same max geodesic error (1, 5, 25, 100, 500 m), and the time of each,
# for the US–Mexico 10m border, the GPS tracks in fixtures/ and synthetic smooth tracks.
#
#   scripts/compression_bench.sh              # the markdown table
#   scripts/compression_bench.sh --ablation   # stored numbers with each idea switched off
#
# Times are wall clock on one thread of whatever machine runs it.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo run --quiet --release --example compression -- "$@"
