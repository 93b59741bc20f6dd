#!/usr/bin/env bash
# spherefit against mapshaper on the same file in one run: wall time and output size of
#   spherefit fit --tolerance-m T --threads N       (two-way bound T on the sphere)
#   mapshaper -simplify dp interval=T               (3-D chord distance on a sphere)
# on the Natural Earth 10m land outlines (npm world-atlas land-10m.json, decoded with
# topojson-client, every ring a closed LineString: 4,037 rings, 408,884 points), and the time of
# the largest ring on its own (one thread).
#
#   scripts/speed_bench.sh                 # T = 100 m, 2 threads
#   T=25 THREADS=1 scripts/speed_bench.sh
#   PREPARE_ONLY=1 scripts/speed_bench.sh  # only install and decode the inputs
#
# npm packages go to target/speed-bench/node (installed on first run); outputs to
# target/speed-bench/.
set -euo pipefail
cd "$(dirname "$0")/.."
T="${T:-100}"
THREADS="${THREADS:-2}"
dir=target/speed-bench
mkdir -p "$dir/node"
if [ ! -x "$dir/node/node_modules/.bin/mapshaper" ]; then
  npm install --silent --prefix "$dir/node" mapshaper@0.6 world-atlas@2 topojson-client@3 >/dev/null
fi
cargo build --quiet --release --bin spherefit

if [ ! -s "$dir/land10m_rings.geojson" ]; then
  node -e '
    const path = require("path");
    const base = path.resolve(process.argv[1], "node_modules");
    const topojson = require(path.join(base, "topojson-client"));
    const topo = require(path.join(base, "world-atlas/land-10m.json"));
    const land = topojson.feature(topo, topo.objects.land);
    const features = [];
    for (const f of land.features) {
      const polys = f.geometry.type === "Polygon" ? [f.geometry.coordinates] : f.geometry.coordinates;
      for (const poly of polys) for (const ring of poly)
        features.push({type: "Feature", properties: {ring: features.length},
                       geometry: {type: "LineString", coordinates: ring}});
    }
    features.sort((a, b) => a.properties.ring - b.properties.ring);
    require("fs").writeFileSync(process.argv[2], JSON.stringify({type: "FeatureCollection", features}));
    let big = features[0];
    for (const f of features) if (f.geometry.coordinates.length > big.geometry.coordinates.length) big = f;
    require("fs").writeFileSync(process.argv[3], JSON.stringify({type: "FeatureCollection", features: [big]}));
  ' "$dir/node" "$dir/land10m_rings.geojson" "$dir/largest_ring.geojson"
fi

if [ -n "${PREPARE_ONLY:-}" ]; then
  exit 0
fi

points() { python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); print(len(d["features"]), sum(len(f["geometry"]["coordinates"]) for f in d["features"]))' "$1"; }
secs() { /usr/bin/time -f %e "$@" 2>&1 >/dev/null | tail -1; }

read -r rings pts < <(points "$dir/land10m_rings.geojson")
read -r _ big < <(points "$dir/largest_ring.geojson")
echo "input: $rings rings, $pts points; largest ring $big points; T = $T m"

t_sf=$(secs target/release/spherefit fit --tolerance-m "$T" --threads "$THREADS" \
  -o "$dir/spherefit.geojson" "$dir/land10m_rings.geojson")
t_ms=$(secs "$dir/node/node_modules/.bin/mapshaper" -i "$dir/land10m_rings.geojson" \
  -simplify dp interval="$T" -o "$dir/mapshaper.geojson" force)
t_big=$(secs target/release/spherefit fit --tolerance-m "$T" --threads 1 \
  -o "$dir/largest.geojson" "$dir/largest_ring.geojson")

python3 - "$dir" "$t_sf" "$t_ms" "$t_big" "$THREADS" <<'PY'
import json, sys
d, t_sf, t_ms, t_big, threads = sys.argv[1], *map(float, sys.argv[2:5]), sys.argv[5]
sf = json.load(open(f"{d}/spherefit.geojson"))
ms = json.load(open(f"{d}/mapshaper.geojson"))
fits = [f["properties"].get("fit", {}) for f in sf["features"]]
stored = sum(f.get("stored_numbers", 0) for f in fits)
met = sum(1 for f in fits if f.get("tolerance_met"))
worst = max(f.get("two_way_distance_m", 0) for f in fits)
ms_numbers = sum(2 * len(f["geometry"]["coordinates"]) for f in ms["features"] if f.get("geometry"))
big = json.load(open(f"{d}/largest.geojson"))["features"][0]["properties"]["fit"]
print(f"spherefit ({threads} threads): {t_sf:.2f} s, {stored} stored numbers, "
      f"{met}/{len(fits)} met, worst two-way {worst:.1f} m")
print(f"mapshaper dp:          {t_ms:.2f} s, {ms_numbers} numbers (vertex coordinates)")
print(f"ratio spherefit / mapshaper time: {t_sf / t_ms:.2f}")
print(f"largest ring alone (1 thread): {t_big:.2f} s, {big.get('stored_numbers')} stored numbers, "
      f"two-way {big.get('two_way_distance_m'):.1f} m, met {big.get('tolerance_met')}")
PY
