#!/usr/bin/env bash
# Instruction counts of the tolerance fit (valgrind --tool=callgrind): stable on a shared
# machine where wall times are not. `spherefit fit --tolerance-m T --threads 1` on
#   small_rings: every 8th ring under 200 points of the Natural Earth 10m land outlines
#                (491 rings, 14,183 points)
#   ring16k:     the largest ring under 16,000 points (Greenland, 15,536 points)
#   land10m:     all 4,062 rings (408,953 points; slow under callgrind: LAND=1 to include it)
#
#   scripts/callgrind_bench.sh                  # the release build of this tree
#   BIN=/tmp/spherefit-old scripts/callgrind_bench.sh   # another build, for before/after
#
# Inputs come from scripts/speed_bench.sh (PREPARE_ONLY=1); outputs go to target/speed-bench/.
set -euo pipefail
cd "$(dirname "$0")/.."
T="${T:-100}"
dir=target/speed-bench
command -v valgrind >/dev/null || { echo "valgrind is needed (Debian: apt-get install valgrind)" >&2; exit 1; }
PREPARE_ONLY=1 scripts/speed_bench.sh
if [ -z "${BIN:-}" ]; then
  cargo build --quiet --release --bin spherefit
  BIN=target/release/spherefit
fi
python3 - "$dir" <<'PY'
import json, sys
d = sys.argv[1]
rings = json.load(open(f"{d}/land10m_rings.geojson"))["features"]
small = [f for f in rings if len(f["geometry"]["coordinates"]) < 200][::8]
big = max((f for f in rings if len(f["geometry"]["coordinates"]) < 16000),
          key=lambda f: len(f["geometry"]["coordinates"]))
for name, feats in (("small_rings", small), ("ring16k", [big])):
    json.dump({"type": "FeatureCollection", "features": feats}, open(f"{d}/{name}.geojson", "w"))
PY
inputs=(small_rings ring16k)
[ -n "${LAND:-}" ] && inputs+=(land10m_rings)
for name in "${inputs[@]}"; do
  out=$(valgrind --tool=callgrind --callgrind-out-file=/dev/null "$BIN" fit --tolerance-m "$T" \
    --threads 1 -o "$dir/callgrind_$name.geojson" "$dir/$name.geojson" 2>&1)
  count=$(echo "$out" | sed -n 's/.*Collected : \([0-9]*\).*/\1/p')
  stored=$(echo "$out" | sed -n 's/.* \([0-9]*\) numbers stored.*/\1/p')
  printf '%-14s %16s instructions  %s stored numbers\n' "$name" "$count" "$stored"
done
