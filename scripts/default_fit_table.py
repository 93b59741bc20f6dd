#!/usr/bin/env python3
"""Default fit vs the paper's method vs uniform knots + Gauss-Newton at the same count.

usage: scripts/default_fit_table.py SPHEREFIT_BINARY FILE.geojson [FILE ...]

Each LineString (and Polygon ring) of each file is fitted three ways with `spherefit fit`:
  default  - no options;
  paper    - --knots geodesic --solver gls-pia --parameter-correction false at a quarter of the
             distinct positions (the previous default);
  uniform  - --knots uniform --solver gauss-newton --parameter-correction false at the count the
             default chose.
Prints per file: lines, worst and median max error (m), mean of the mean errors (m), the
certified two-way distances (worst / median for the default, worst for the others), lines where
the default is worse than uniform + Gauss-Newton, and the total control points of the default.
"""
import json, math, subprocess, sys

def fit(binary, feature, args):
    doc = json.dumps({"type": "FeatureCollection", "features": [feature]})
    out = subprocess.run([binary, "fit", "-q", *args], input=doc, capture_output=True, text=True, check=True)
    return json.loads(out.stdout)["features"][0]["properties"]["fit"]

def lines(path):
    for f in json.load(open(path))["features"]:
        g = f["geometry"]
        parts = {"LineString": [g["coordinates"]], "MultiLineString": g["coordinates"],
                 "Polygon": g["coordinates"][:1], "MultiPolygon": [p[0] for p in g["coordinates"]]}.get(g["type"], [])
        for c in parts:
            dedup = [p for i, p in enumerate(c) if i == 0 or p != c[i - 1]]
            if len(dedup) >= 8:
                yield {"type": "Feature", "properties": {}, "geometry": {"type": "LineString", "coordinates": c}}, len(dedup)

def main():
    binary, files = sys.argv[1], sys.argv[2:]
    print("| data | lines | default: worst / median max (m) | mean (m) | two-way worst / median (m) | paper: worst / median max | mean | paper two-way worst | uniform + GN at the default's count: worst / median max | mean | uniform + GN two-way worst | default worse than uniform + GN (max) | control points (default) |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for path in files:
        rows = []
        for feat, n in lines(path):
            d = fit(binary, feat, [])
            p = fit(binary, feat, ["--knots", "geodesic", "--solver", "gls-pia", "--parameter-correction", "false",
                                   "-n", str(max(4, math.ceil(n / 4)))])
            u = fit(binary, feat, ["--knots", "uniform", "--solver", "gauss-newton", "--parameter-correction", "false",
                                   "-n", str(d["control_points"])])
            rows.append((d, p, u))
        if not rows:
            continue
        def stats(k):
            mx = sorted(r[k]["max_error_m"] for r in rows)
            return mx[-1], mx[len(mx) // 2], sum(r[k]["mean_error_m"] for r in rows) / len(rows)
        (dw, dm, da), (pw, pm, pa), (uw, um, ua) = stats(0), stats(1), stats(2)
        def two_way(k):
            tw = sorted(r[k]["two_way_distance_m"] for r in rows)
            return tw[-1], tw[len(tw) // 2]
        (dtw, dtm), (ptw, _), (utw, _) = two_way(0), two_way(1), two_way(2)
        worse = sum(1 for d, _, u in rows if d["max_error_m"] > u["max_error_m"])
        ctrl = sum(r[0]["control_points"] for r in rows)
        print(f"| {path.split('/')[-1]} | {len(rows)} | {dw:,.0f} / {dm:,.0f} | {da:,.0f} | {dtw:,.0f} / {dtm:,.0f} | {pw:,.0f} / {pm:,.0f} | {pa:,.0f} | {ptw:,.0f} | {uw:,.0f} / {um:,.0f} | {ua:,.0f} | {utw:,.0f} | {worse} | {ctrl:,} |")

main()
