#!/usr/bin/env bash
# spherefit against mapshaper across tolerances, in one command: for each T in TOLERANCES,
#   spherefit fit --tolerance-m T --threads THREADS     (two-way bound T on the sphere)
#   mapshaper -simplify dp interval=T                   (3-D chord distance on a sphere)
# on the Natural Earth 10m land outlines (the inputs of scripts/speed_bench.sh), alternated,
# RUNS runs each; prints a Markdown table of the median wall times, their ratio, the stored
# numbers (spherefit's --stats stored_numbers; mapshaper: 2 x output vertices), the rings that
# met the tolerance (from spherefit's per-ring fit report), the worst certified two-way
# distance, and, on the rings mapshaper keeps (it drops rings that collapse; spherefit keeps
# them as small valid rings unless --drop-small-rings), spherefit's stored numbers and the
# rings where it stores more than mapshaper's vertex coordinates plus its one degree number.
#
#   scripts/speed_table.sh                         # T = 10 m, 100 m, 1 km, 5 km; 5 runs each
#   RUNS=1 scripts/speed_table.sh                  # a quick look
#   TOLERANCES="1000 5000" THREADS=1 scripts/speed_table.sh
#   BIN=/tmp/spherefit-old scripts/speed_table.sh  # another build, for before/after
#
# Outputs go to target/speed-bench/table/.
set -euo pipefail
cd "$(dirname "$0")/.."
RUNS="${RUNS:-5}"
THREADS="${THREADS:-2}"
TOLERANCES="${TOLERANCES:-10 100 1000 5000}"
dir=target/speed-bench
out="$dir/table"
mkdir -p "$out"
if [ ! -s "$dir/land10m_rings.geojson" ] || [ ! -x "$dir/node/node_modules/.bin/mapshaper" ]; then
  PREPARE_ONLY=1 scripts/speed_bench.sh
fi
if [ -z "${BIN:-}" ]; then
  cargo build --quiet --release --bin spherefit
  BIN=target/release/spherefit
fi
mapshaper="$dir/node/node_modules/.bin/mapshaper"
input="$dir/land10m_rings.geojson"

secs() { /usr/bin/time -f %e "$@" 2>&1 >/dev/null | tail -1; }
median() { tr ' ' '\n' | grep . | sort -g | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }

echo "tree at commit $(git rev-parse --short HEAD)$(git diff --quiet HEAD -- src || echo '+dirty'), $(date -u '+%Y-%m-%d %H:%M UTC'), load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "RUNS=$RUNS THREADS=$THREADS BIN=$BIN"
echo
echo "| T | spherefit (median s) | mapshaper (median s) | ratio | spherefit stored | mapshaper numbers | rings met | worst two-way | rings mapshaper drops | spherefit stored on the rings mapshaper keeps | rings storing more than mapshaper |"
echo "|---|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|"
for T in $TOLERANCES; do
  sf=""
  ms=""
  for _ in $(seq "$RUNS"); do
    sf+=" $(secs "$BIN" fit --tolerance-m "$T" --threads "$THREADS" -q --stats="$out/stats_$T.json" \
      -o "$out/spherefit_$T.geojson" "$input")"
    ms+=" $(secs "$mapshaper" -i "$input" -simplify dp interval="$T" \
      -o "$out/mapshaper_$T.geojson" force)"
  done
  python3 - "$out" "$T" "$(echo "$sf" | median)" "$(echo "$ms" | median)" <<'PY'
import json, sys
out, T, t_sf, t_ms = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])
stats = json.load(open(f"{out}/stats_{T}.json"))
sf = json.load(open(f"{out}/spherefit_{T}.geojson"))["features"]
ms = json.load(open(f"{out}/mapshaper_{T}.geojson"))["features"]
fits = [f["properties"].get("fit", {}) for f in sf]
met = sum(1 for f in fits if f.get("tolerance_met"))
worst = max(f.get("two_way_distance_m", 0) for f in fits)
ms_by_ring = {f["properties"]["ring"]: 2 * len(f["geometry"]["coordinates"])
              for f in ms if f.get("geometry")}
ms_numbers = sum(ms_by_ring.values())
# The degree is one stored number of every spherefit curve; a ring storing the same vertices
# as mapshaper's stores one number more, so "more" counts rings beyond that.
kept = [(fit.get("stored_numbers", 0), ms_by_ring[f["properties"]["ring"]])
        for f, fit in zip(sf, fits) if f["properties"]["ring"] in ms_by_ring]
more = sum(1 for s, m in kept if s > m + 1)
label = f"{int(T) // 1000} km" if int(T) >= 1000 else f"{T} m"
print(f"| {label} | {t_sf:.2f} | {t_ms:.2f} | {t_sf / t_ms:.2f} | {stats['stored_numbers']:,} | "
      f"{ms_numbers:,} | {met:,} of {len(fits):,} | {worst:.1f} m | {len(sf) - len(kept):,} | "
      f"{sum(s for s, _ in kept):,} | {more:,} |")
PY
done
