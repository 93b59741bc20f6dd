#!/usr/bin/env bash
# The compression bench: numbers and bytes stored by fit_to_tolerance, a spherical
# Douglas–Peucker and the optimal subset polyline at the same tolerance (1, 5, 25, 100, 500 m),
# their certified two-way distances to the line, and the time of each,
# for the US–Mexico borders, the GPS tracks in fixtures/ and synthetic lines.
#
#   scripts/compression_bench.sh              # the markdown table
#   scripts/compression_bench.sh --noisy-points 2000    # a shorter noisy 1 Hz track (default 16,000)
#   scripts/compression_bench.sh --ablation   # stored numbers with each idea switched off
#   scripts/compression_bench.sh --time       # tracks in time: bytes per hour at SED 5, 10, 25, 100 m against TD-TR
#
# Times are wall clock on one thread of whatever machine runs it.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --quiet --release --example compression
# One thread: the two-way checks would otherwise use every core, and the times are per core.
RAYON_NUM_THREADS="${RAYON_NUM_THREADS:-1}" target/release/examples/compression "$@"
