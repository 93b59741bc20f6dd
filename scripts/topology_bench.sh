#!/usr/bin/env bash
# Coverage fitting against per-feature fitting and mapshaper, on polygon coverages at 100 m and
# 1 km: stored numbers (spherefit: 2 per control point, knots, degree; arcs counted once with
# --topology shared; mapshaper: 2 per vertex of its TopoJSON arcs, each arc once), wall time,
# and the gap between neighbours' output borders (scripts/coverage_gap.py). Also checks that
# GDAL (ogrinfo) and mapshaper read spherefit's TopoJSON.
#   npm ci --prefix scripts/coverage && cargo build --release && scripts/topology_bench.sh
set -euo pipefail
cd "$(dirname "$0")/.."
B=target/release/spherefit
MS=scripts/coverage/node_modules/.bin/mapshaper
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
# The whole us-atlas states-10m (56 states and territories) besides the fixtures.
node -e '
const r = require("module").createRequire(process.cwd() + "/scripts/coverage/package.json");
const t = r("topojson-client"), us = r("us-atlas/states-10m.json");
process.stdout.write(JSON.stringify(t.feature(us, us.objects.states)));' > "$T/us_states_all.geojson"
now() { date +%s.%N; }
printf '| data | tolerance | per-feature numbers | per-feature s | per-feature gap p95 / max m | shared numbers | shared s | shared gap max m | mapshaper dp numbers | mapshaper s |\n'
printf '|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n'
for data in "$T/us_states_all.geojson" fixtures/coverage_world_110m.geojson; do
  name=$(basename "$data" .geojson)
  for tol in 100 1000; do
    # (world-atlas has one degenerate ring, North Korea's; per-feature fitting refuses that
    # feature, with exit status 1, and writes the others.)
    "$B" fit -q --tolerance-m "$tol" --stats="$T/pf.json" "$data" -o "$T/pf.geojson" 2> /dev/null || true
    pf_n=$(python3 -c "import json;print(json.load(open('$T/pf.json'))['stored_numbers'])")
    pf_s=$(python3 -c "import json;print(round(json.load(open('$T/pf.json'))['seconds'],2))")
    pf_gap=$(python3 scripts/coverage_gap.py "$data" "$T/pf.geojson" | sed -E 's/.*p95 ([0-9.]+) m, max ([0-9.]+) m.*/\1 \/ \2/')
    "$B" fit -q --topology shared --tolerance-m "$tol" --stats="$T/sh.json" "$data" -o "$T/sh.geojson"
    sh_n=$(python3 -c "import json;print(json.load(open('$T/sh.json'))['stored_numbers'])")
    sh_s=$(python3 -c "import json;print(round(json.load(open('$T/sh.json'))['seconds'],2))")
    sh_gap=$(python3 scripts/coverage_gap.py "$data" "$T/sh.geojson" | sed -E 's/.*max ([0-9.]+) m.*/\1/')
    # mapshaper: Douglas–Peucker with its interval in metres (spherical for lon/lat data),
    # shared topology kept; numbers = 2 x vertices of the output arcs, without quantisation.
    t0=$(now)
    "$MS" -i "$data" -simplify dp interval="$tol" -o "$T/ms.topojson" format=topojson no-quantization 2> /dev/null
    t1=$(now)
    ms_n=$(python3 -c "import json;t=json.load(open('$T/ms.topojson'));print(2*sum(len(a) for a in t['arcs']))")
    ms_s=$(python3 -c "print(round($t1-$t0,2))")
    printf '| %s | %s m | %s | %s | %s | %s | %s | %s | %s | %s |\n' "$name" "$tol" "$pf_n" "$pf_s" "$pf_gap" "$sh_n" "$sh_s" "$sh_gap" "$ms_n" "$ms_s"
  done
done
# The TopoJSON output read back by GDAL and mapshaper.
"$B" fit -q --topology shared --tolerance-m 1000 --output-format topojson fixtures/coverage_world_110m.geojson -o "$T/world.topojson"
if command -v ogrinfo > /dev/null; then
  ogrinfo -ro -al -so "$T/world.topojson" | grep -E "driver|Feature Count" | head -3
fi
"$MS" -i "$T/world.topojson" -info 2>&1 | grep -E "Layer name|Records|Geometry" | head -4
