#!/usr/bin/env bash
# Coverage mode against mapshaper, in one command: on the npm world-atlas 2.0.2 countries-10m
# (255 features, 544,898 points; decoded to GeoJSON with topojson-client, as
# scripts/bytes_bench.sh does), at T (1 km unless told),
#   spherefit fit -q --topology shared --tolerance-m T --output-format topojson --threads THREADS
#   mapshaper -i IN -simplify dp interval=T -o OUT format=topojson
# alternated, RUNS runs each. Prints a Markdown row: the median wall times (whole commands,
# Node's start included), their ratio, the numbers stored (spherefit's --stats stored_numbers,
# arcs once; mapshaper: 2 x the vertices of its TopoJSON arcs, each arc once), and then where
# spherefit's time goes: each step of its --stats `phases` (median over the runs), its share of
# spherefit's own seconds, and the same step in one run with --threads 1 (a step that takes as
# long with one thread as with two runs on one).
#
#   scripts/coverage_speed.sh                        # T = 1 km, 5 runs each, 2 threads
#   RUNS=1 scripts/coverage_speed.sh                 # a quick look
#   T=100 THREADS=1 scripts/coverage_speed.sh
#   BIN=/tmp/spherefit-old scripts/coverage_speed.sh # another build, for before/after
#
# Needs node and npm (npm ci --prefix scripts/coverage is run when mapshaper is missing).
# Outputs go to target/coverage-speed/.
set -euo pipefail
cd "$(dirname "$0")/.."
RUNS="${RUNS:-5}"
THREADS="${THREADS:-2}"
T="${T:-1000}"
out=target/coverage-speed
mkdir -p "$out"
[ -x scripts/coverage/node_modules/.bin/mapshaper ] || npm ci --silent --prefix scripts/coverage >/dev/null
input="$out/countries10m.geojson"
[ -s "$input" ] || node scripts/coverage/topojson_read.mjs world-atlas countries-10m "$input" >/dev/null
if [ -z "${BIN:-}" ]; then
  cargo build --quiet --release --bin spherefit
  BIN=target/release/spherefit
fi
mapshaper=scripts/coverage/node_modules/.bin/mapshaper

secs() { /usr/bin/time -f %e "$@" 2>&1 >/dev/null | tail -1; }
median() { tr ' ' '\n' | grep . | sort -g | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }
spherefit() { # threads stats-file: the command line
  echo "$BIN" fit -q --topology shared --tolerance-m "$T" --output-format topojson --threads "$1" \
    --stats="$2" -o "$out/spherefit_$T.topojson" "$input"
}

echo "tree at commit $(git rev-parse --short HEAD)$(git diff --quiet HEAD -- src || echo '+dirty'), $(date -u '+%Y-%m-%d %H:%M UTC'), load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "RUNS=$RUNS THREADS=$THREADS T=$T BIN=$BIN"
echo
sf=""
ms=""
rm -f "$out"/stats_"$T"_*.json
for r in $(seq "$RUNS"); do
  # shellcheck disable=SC2046 # the words of a command line without spaces in them
  sf+=" $(secs $(spherefit "$THREADS" "$out/stats_${T}_$r.json"))"
  ms+=" $(secs "$mapshaper" -i "$input" -simplify dp interval="$T" \
    -o "$out/mapshaper_$T.topojson" format=topojson)"
done
# shellcheck disable=SC2046
$(spherefit 1 "$out/stats_${T}_one_thread.json")
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
echo
python3 - "$out" "$T" "$RUNS" "$THREADS" "$(echo "$sf" | median)" "$(echo "$ms" | median)" "$sf" "$ms" <<'PY'
import json, statistics, sys
out, T, runs, threads = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
t_sf, t_ms, all_sf, all_ms = float(sys.argv[5]), float(sys.argv[6]), sys.argv[7], sys.argv[8]
stats = [json.load(open(f"{out}/stats_{T}_{r}.json")) for r in range(1, runs + 1)]
one = json.load(open(f"{out}/stats_{T}_one_thread.json"))
topo = json.load(open(f"{out}/mapshaper_{T}.topojson"))
ms_numbers = 2 * sum(len(a) for a in topo["arcs"])
label = f"{T // 1000} km" if T >= 1000 and T % 1000 == 0 else f"{T} m"
print("| T | spherefit (median s) | mapshaper (median s) | ratio | spherefit stored | mapshaper numbers |")
print("|---|---:|---:|---:|---:|---:|")
print(f"| {label} | {t_sf:.2f} | {t_ms:.2f} | {t_sf / t_ms:.2f} | {stats[0]['stored_numbers']:,} | {ms_numbers:,} |")
print()
print(f"(all runs, s: spherefit{all_sf}; mapshaper{all_ms})")
print()
names = [name for name, _ in stats[0].get("phases", [])]
if names:
    seconds = statistics.median(s["seconds"] for s in stats)
    one_thread = dict(one.get("phases", []))
    print(f"| spherefit step | median s, {threads} threads | share | s, 1 thread (one run) |")
    print("|---|---:|---:|---:|")
    for k, name in enumerate(names):
        med = statistics.median(s["phases"][k][1] for s in stats)
        print(f"| {name} | {med:.3f} | {100 * med / seconds:.0f} % | {one_thread.get(name, float('nan')):.3f} |")
    print(f"| (spherefit's own seconds) | {seconds:.3f} | | {one['seconds']:.3f} |")
else:
    print("(this build reports no phases in --stats)")
PY
