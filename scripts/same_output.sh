#!/usr/bin/env bash
# Two builds give byte-identical outputs (for refactors that must not change a number): runs each
# of a fixed set of fits with OLD and NEW and compares the outputs with cmp.
#
#   scripts/same_output.sh OLD_BIN NEW_BIN          # e.g. /tmp/spherefit-before target/release/spherefit
#   QUICK=1 scripts/same_output.sh OLD NEW          # fixtures only (seconds)
#
# The inputs: every GeoJSON fixture (default fit, fit to 1 km, carry=spline, in time where it has
# times, shared topology to TopoJSON on the coverages), then the 10m land outlines
# (scripts/speed_bench.sh decodes them) at 100 m and 1 km and the world-atlas countries-10m
# (scripts/coverage_speed.sh decodes it) per feature and shared at 1, 5 and 20 km.
# Outputs go to target/same-output/{old,new}/; exits 1 on the first list of differences.
set -euo pipefail
cd "$(dirname "$0")/.."
OLD="$1"
NEW="$2"
out=target/same-output
# OLD's outputs are kept while OLD is the same binary (a refactor compares many NEWs with one OLD).
old_sum=$(sha256sum "$OLD" | cut -c1-16)
[ "$(cat "$out/old/.binary" 2>/dev/null)" = "$old_sum" ] || rm -rf "$out/old"
rm -rf "$out/new"
mkdir -p "$out/old" "$out/new"
echo "$old_sum" >"$out/old/.binary"
runs=()
add() { runs+=("$*"); }   # name then the arguments of spherefit
for f in fixtures/*.geojson; do
  b=$(basename "$f" .geojson)
  add "$b.default" fit -q "$f"
  add "$b.1km" fit -q --tolerance-m 1000 "$f"
  add "$b.spline" fit -q --tolerance-m 1000 --carry spline "$f"
done
add gps.time fit -q --time-property timestamps_unix_s --tolerance-m 10 fixtures/gps_tracks_slovenia_gpxpy.geojson
add batch.tracks fit -q --tolerance-m 100 fixtures/batch_tracks.geojsons
for f in fixtures/coverage_us_states.geojson fixtures/coverage_world_110m.geojson fixtures/world_atlas_10m_cyprus.geojson; do
  b=$(basename "$f" .geojson)
  add "$b.shared" fit -q --topology shared --tolerance-m 5000 "$f"
  add "$b.topojson" fit -q --topology shared --tolerance-m 5000 --output-format topojson "$f"
done
add sphere.fit sphere fit --control-points 12 fixtures/sphere_wavy_points.json
if [ -z "${QUICK:-}" ]; then
  land=target/speed-bench/land10m_rings.geojson
  countries=target/coverage-speed/countries10m.geojson
  [ -s "$land" ] || PREPARE_ONLY=1 scripts/speed_bench.sh
  if [ ! -s "$countries" ]; then
    [ -x scripts/coverage/node_modules/.bin/mapshaper ] || npm ci --silent --prefix scripts/coverage >/dev/null
    mkdir -p target/coverage-speed
    node scripts/coverage/topojson_read.mjs world-atlas countries-10m "$countries" >/dev/null
  fi
  add land.100m fit -q --tolerance-m 100 "$land"
  add land.1km fit -q --tolerance-m 1000 "$land"
  for T in 1000 5000 20000; do
    add "countries.$T" fit -q --tolerance-m "$T" "$countries"
    add "countries.shared.$T" fit -q --topology shared --tolerance-m "$T" "$countries"
    add "countries.topojson.$T" fit -q --topology shared --output-format topojson --tolerance-m "$T" "$countries"
  done
fi
diffs=()
for r in "${runs[@]}"; do
  set -- $r
  name="$1"; shift
  for side in old new; do
    bin="$OLD"; [ "$side" = new ] && bin="$NEW"
    [ "$side" = old ] && [ -f "$out/old/$name.err" ] && continue
    rc=0
    "$bin" "$@" >"$out/$side/$name.out" 2>"$out/$side/$name.err" || rc=$?
    echo "exit $rc" >>"$out/$side/$name.err"
  done
  cmp -s "$out/old/$name.out" "$out/new/$name.out" && cmp -s "$out/old/$name.err" "$out/new/$name.err" \
    || diffs+=("$name")
done
echo "${#runs[@]} runs compared"
if [ "${#diffs[@]}" -gt 0 ]; then
  echo "differ: ${diffs[*]}"
  exit 1
fi
echo "all byte-identical"
