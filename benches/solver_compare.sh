#!/usr/bin/env bash
# The fast-solver bench: 1M points, 2k control points, cubic on S^2.
# Runs spherefit's Gauss–Newton fit (all cores, then one) and scipy's Euclidean make_lsq_spline
# on the same points and knots, each under /usr/bin/time -v for peak memory, and prints the
# ratio. Needs `pip install numpy scipy`. Usage: benches/solver_compare.sh [points] [controls]
set -euo pipefail
cd "$(dirname "$0")/.."
n=${1:-1000000}; m=${2:-2000}
dir=$(mktemp -d); trap 'rm -rf "$dir"' EXIT
cargo build --release --quiet --example fit_large
ex=target/release/examples/fit_large
"$ex" "$n" "$m" gauss-newton --dump "$dir" >/dev/null   # writes the shared inputs
run() { # label, command...
  local label=$1; shift
  /usr/bin/time -v "$@" 2>"$dir/time.txt" >"$dir/out.json"
  local rss; rss=$(awk -F': ' '/Maximum resident/ {printf "%.0f", $2/1024}' "$dir/time.txt")
  python3 - "$label" "$rss" "$dir/out.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[3])); r["label"] = sys.argv[1]; r["peak_rss_mb"] = int(sys.argv[2])
print(json.dumps(r))
PY
}
ours2=$(run "spherefit gauss-newton, 2 threads" "$ex" "$n" "$m" gauss-newton)
ours1=$(RAYON_NUM_THREADS=1 run "spherefit gauss-newton, 1 thread" "$ex" "$n" "$m" gauss-newton)
theirs=$(run "scipy make_lsq_spline" python3 benches/scipy_lsq.py "$dir")
printf '%s\n%s\n%s\n' "$ours2" "$ours1" "$theirs"
python3 - "$ours2" "$theirs" <<'PY'
import json, sys
a, b = json.loads(sys.argv[1]), json.loads(sys.argv[2])
print(f"time ratio spherefit(2 threads) / scipy = {a['seconds'] / b['seconds']:.2f}; "
      f"rms ratio = {a['rms_error_rad'] / b['rms_error_rad']:.3f}; "
      f"peak RSS {a['peak_rss_mb']} MB vs {b['peak_rss_mb']} MB (scipy includes the Python runtime)")
PY
