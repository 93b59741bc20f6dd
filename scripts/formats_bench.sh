#!/usr/bin/env bash
# Reading the Natural Earth 10m land outlines (4,037 rings as LineStrings, 408,884 points; the
# input of scripts/speed_bench.sh) from Shapefile, GeoPackage and FlatGeobuf against reading
# the GeoJSON: wall time and peak memory (/usr/bin/time -v) of
#   spherefit fit --tolerance-m T --threads N INPUT -o OUT.geojson
# for each input format (the difference to the GeoJSON run is what reading the format costs),
# and of GDAL converting each file to GeoJSON (ogr2ogr -f GeoJSON /vsistdout/, written to
# /dev/null), best of RUNS runs each.
#
#   scripts/formats_bench.sh               # T = 100 m, 2 threads, 3 runs
#   T=1000 RUNS=5 scripts/formats_bench.sh
#   BIN=/tmp/spherefit scripts/formats_bench.sh   # that binary, not built
#
# Needs npm (world-atlas, topojson-client: installed by speed_bench.sh) and GDAL's ogr2ogr
# (Debian gdal-bin) to make the inputs. Outputs go to target/formats-bench/.
set -euo pipefail
cd "$(dirname "$0")/.."
T="${T:-100}"
THREADS="${THREADS:-2}"
RUNS="${RUNS:-3}"
dir=target/formats-bench
mkdir -p "$dir"
src=target/speed-bench/land10m_rings.geojson
[ -s "$src" ] || PREPARE_ONLY=1 scripts/speed_bench.sh
# BIN=path measures that binary as it is (no build).
if [ -z "${BIN:-}" ]; then
  cargo build --quiet --release --bin spherefit
fi
bin=${BIN:-target/release/spherefit}

[ -s "$dir/land.shp" ] || ogr2ogr -f "ESRI Shapefile" -lco ENCODING=UTF-8 "$dir/land.shp" "$src"
[ -s "$dir/land.gpkg" ] || ogr2ogr -f GPKG "$dir/land.gpkg" "$src" -nln land
[ -s "$dir/land.fgb" ] || ogr2ogr -f FlatGeobuf -lco SPATIAL_INDEX=NO "$dir/land.fgb" "$src"
cp -f "$src" "$dir/land.geojson"

# "seconds peak_MB" of a command: the best wall time of RUNS runs and the peak RSS of that run.
measure() {
  local best="" mem=""
  for _ in $(seq "$RUNS"); do
    local out
    out=$(/usr/bin/time -v "$@" 2>&1 >/dev/null | awk -F': ' '
      /Elapsed \(wall clock\)/ { n = split($2, p, ":"); s = 0; for (i = 1; i <= n; i++) s = s * 60 + p[i] }
      /Maximum resident set size/ { m = $2 / 1024 }
      END { printf "%.2f %.0f", s, m }')
    local s=${out% *} m=${out#* }
    if [ -z "$best" ] || awk -v a="$s" -v b="$best" 'BEGIN { exit !(a < b) }'; then
      best=$s mem=$m
    fi
  done
  echo "$best $mem"
}

echo "T = $T m, $THREADS threads, best of $RUNS; input: $(du -h "$dir/land.geojson" | cut -f1) GeoJSON"
printf '| input | size | spherefit fit (s) | peak (MB) | vs GeoJSON | ogr2ogr -f GeoJSON (s) | peak (MB) |\n'
printf '|---|---|---|---|---|---|---|\n'
base=""
for f in land.geojson land.shp land.gpkg land.fgb; do
  read -r s m < <(measure "$bin" fit -q --tolerance-m "$T" --threads "$THREADS" "$dir/$f" -o "$dir/out.geojson")
  base=${base:-$s}
  rel=$(awk -v a="$s" -v b="$base" 'BEGIN { printf "%+.0f %%", (a / b - 1) * 100 }')
  if [ "$f" = land.geojson ]; then
    og="-" ogm="-"
  else
    read -r og ogm < <(measure ogr2ogr -f GeoJSON /vsistdout/ "$dir/$f")
  fi
  size=$(du -h "$dir/$f" | cut -f1)
  [ "$f" = land.shp ] && size="$(du -ch "$dir"/land.shp "$dir"/land.dbf "$dir"/land.shx | tail -1 | cut -f1)"
  printf '| %s | %s | %s | %s | %s | %s | %s |\n' "${f#land.}" "$size" "$s" "$m" "$rel" "$og" "$ogm"
done
