#!/usr/bin/env bash
# Bytes of spherefit's outputs against mapshaper's, raw and gzipped, each with its measured
# distance to the input (#30). One command, one run:
#
#   scripts/bytes_bench.sh
#
# Data (npm world-atlas 2.0.2, Natural Earth, public domain, decoded with topojson-client):
#   * the 10m land outlines, every ring a closed LineString (4,037 rings, 408,884 points; the
#     input of scripts/speed_bench.sh), at T = 100 m, per feature;
#   * the 50m and 10m countries as a coverage (spherefit --topology shared) at T = 1 km.
# Tools: mapshaper 0.7.70 and topojson-client 3.1.0 from scripts/coverage (npm ci there),
# `-simplify dp interval=T keep-shapes`, GeoJSON and TopoJSON quantization=1e6 (its
# documented default for TopoJSON output is none; 1e6 is what the issue measured) and 1e5.
# Distance: examples/bytes_distance.rs, the sampled Hausdorff distance both ways between each
# output (TopoJSON read back with topojson-client) and the input, per feature, in metres; it
# is never above the ordered two-way distance spherefit certifies (its `two_way_distance_m`,
# printed as "certified" for spherefit's rows).
# Outputs go to target/bytes-bench/.
set -euo pipefail
cd "$(dirname "$0")/.."
dir=target/bytes-bench
mkdir -p "$dir"
[ -x scripts/coverage/node_modules/.bin/mapshaper ] || npm ci --silent --prefix scripts/coverage >/dev/null
cargo build --quiet --release --bin spherefit --example bytes_distance
PREPARE_ONLY=1 scripts/speed_bench.sh >/dev/null
cp target/speed-bench/land10m_rings.geojson "$dir/land.geojson"
for n in 50m 10m; do
  [ -s "$dir/countries$n.geojson" ] || node scripts/coverage/topojson_read.mjs world-atlas "countries-$n" "$dir/countries$n.geojson"
done
sf=target/release/spherefit
ms=scripts/coverage/node_modules/.bin/mapshaper
dist=target/release/examples/bytes_distance

row() { # name file input tol [geojson-for-distance] [certified]
  local name=$1 file=$2 input=$3 tol=$4 geo=${5:-$2} cert=${6:-}
  local raw gz d
  raw=$(stat -c %s "$file")
  gz=$(gzip -9 -c "$file" | wc -c)
  d=$("$dist" "$input" "$geo" "$tol")
  printf '| %s | %s | %s | %s | %s |\n' "$name" "$raw" "$gz" "$d" "${cert:--}"
}
certified() { # the worst two_way_distance_m of a spherefit GeoJSON output
  python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))
vals = [f["properties"]["fit"].get("two_way_distance_m", 0) for f in d["features"] if (f.get("properties") or {}).get("fit")]
met = all(f["properties"]["fit"].get("tolerance_met") for f in d["features"] if (f.get("properties") or {}).get("fit"))
print(f"{max(vals):.2f}" + ("" if met else " (not all met)"))' "$1"
}
topo_read() { node scripts/coverage/topojson_read.mjs read "$1" "$2"; }

echo "| output | bytes | gzip -9 bytes | measured distance m | certified two-way m |"
echo "|---|---:|---:|---:|---:|"
in=$dir/land.geojson
printf '| **land 10m, 100 m** (input) | %s | %s | 0 | - |\n' "$(stat -c %s "$in")" "$(gzip -9 -c "$in" | wc -c)"
$sf fit -q --tolerance-m 100 "$in" -o "$dir/land.sf.both.geojson"
$sf fit -q --tolerance-m 100 --carry geometry "$in" -o "$dir/land.sf.geometry.geojson"
$sf fit -q --tolerance-m 100 --carry spline "$in" -o "$dir/land.sf.spline.geojson"
$sf fit -q --tolerance-m 100 --topology shared --carry geometry --output-format topojson "$in" -o "$dir/land.sf.topojson"
$sf fit -q --tolerance-m 100 --topology shared --carry geometry "$in" -o "$dir/land.sf.shared.geojson"
cert=$(certified "$dir/land.sf.geometry.geojson")
row "spherefit GeoJSON, carry both (default)" "$dir/land.sf.both.geojson" "$in" 100 "" "$cert"
row "spherefit GeoJSON, carry geometry" "$dir/land.sf.geometry.geojson" "$in" 100 "" "$cert"
$sf evaluate -q "$dir/land.sf.spline.geojson" -o "$dir/land.sf.spline.drawn.geojson"
row "spherefit GeoJSON, carry spline (compact curves)" "$dir/land.sf.spline.geojson" "$in" 100 "$dir/land.sf.spline.drawn.geojson" "$cert"
topo_read "$dir/land.sf.topojson" "$dir/land.sf.topojson.geojson"
row "spherefit TopoJSON, carry geometry" "$dir/land.sf.topojson" "$in" 100 "$dir/land.sf.topojson.geojson" "$(certified "$dir/land.sf.shared.geojson")"
$ms -i "$in" -simplify dp interval=100 keep-shapes -o "$dir/land.ms.geojson" format=geojson force 2>/dev/null
row "mapshaper GeoJSON" "$dir/land.ms.geojson" "$in" 100
for q in 1e6 1e5; do
  $ms -i "$in" -simplify dp interval=100 keep-shapes -o "$dir/land.ms.$q.topojson" format=topojson quantization=$q force 2>/dev/null
  topo_read "$dir/land.ms.$q.topojson" "$dir/land.ms.$q.topojson.geojson"
  row "mapshaper TopoJSON quantization=$q" "$dir/land.ms.$q.topojson" "$in" 100 "$dir/land.ms.$q.topojson.geojson"
done

for n in 50m 10m; do
  in=$dir/countries$n.geojson
  printf '| **countries %s, 1 km, shared** (input) | %s | %s | 0 | - |\n' "$n" "$(stat -c %s "$in")" "$(gzip -9 -c "$in" | wc -c)"
  $sf fit -q --tolerance-m 1000 --topology shared --carry geometry "$in" -o "$dir/c$n.sf.geojson"
  $sf fit -q --tolerance-m 1000 --topology shared --carry geometry --output-format topojson "$in" -o "$dir/c$n.sf.topojson"
  $sf fit -q --tolerance-m 1000 --topology shared --output-format topojson "$in" -o "$dir/c$n.sf.both.topojson"
  cert=$(certified "$dir/c$n.sf.geojson")
  row "spherefit GeoJSON, carry geometry" "$dir/c$n.sf.geojson" "$in" 1000 "" "$cert"
  topo_read "$dir/c$n.sf.topojson" "$dir/c$n.sf.topojson.geojson"
  row "spherefit TopoJSON, carry geometry" "$dir/c$n.sf.topojson" "$in" 1000 "$dir/c$n.sf.topojson.geojson" "$cert"
  topo_read "$dir/c$n.sf.both.topojson" "$dir/c$n.sf.both.topojson.geojson"
  row "spherefit TopoJSON, carry both (splines)" "$dir/c$n.sf.both.topojson" "$in" 1000 "$dir/c$n.sf.both.topojson.geojson" "$cert"
  $ms -i "$in" -simplify dp interval=1000 keep-shapes -o "$dir/c$n.ms.geojson" format=geojson force 2>/dev/null
  row "mapshaper GeoJSON" "$dir/c$n.ms.geojson" "$in" 1000
  for q in 1e6 1e5; do
    $ms -i "$in" -simplify dp interval=1000 keep-shapes -o "$dir/c$n.ms.$q.topojson" format=topojson quantization=$q force 2>/dev/null
    topo_read "$dir/c$n.ms.$q.topojson" "$dir/c$n.ms.$q.topojson.geojson"
    row "mapshaper TopoJSON quantization=$q" "$dir/c$n.ms.$q.topojson" "$in" 1000 "$dir/c$n.ms.$q.topojson.geojson"
  done
done
