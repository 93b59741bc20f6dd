#!/usr/bin/env python3
"""Gaps between neighbours' fitted borders: for every input vertex inside a border shared by
two polygon features (both incident input edges shared by exactly that pair), the distance
from the point of feature A's output boundary nearest to the vertex to feature B's output
boundary (great-circle segments, metres). 0 means the neighbours' outputs coincide there.

    python3 scripts/coverage_gap.py INPUT.geojson OUTPUT.geojson

Prints the number of vertices measured, the median, p95 and max gap, and the share over 10 m.
"""
import json, math, sys

R = 6371008.8

def unit(p):
    lo, la = math.radians(p[0]), math.radians(p[1])
    return (math.cos(la) * math.cos(lo), math.cos(la) * math.sin(lo), math.sin(la))

def cross(a, b):
    return (a[1]*b[2]-a[2]*b[1], a[2]*b[0]-a[0]*b[2], a[0]*b[1]-a[1]*b[0])

def dot(a, b):
    return a[0]*b[0]+a[1]*b[1]+a[2]*b[2]

def angle(a, b):
    c = cross(a, b)
    return math.atan2(math.sqrt(dot(c, c)), dot(a, b))

def nearest_on_segment(p, a, b):
    """(distance, nearest point) from p to the great-circle segment a-b."""
    n = cross(a, b)
    l = math.sqrt(dot(n, n))
    if l > 1e-15:
        n = (n[0]/l, n[1]/l, n[2]/l)
        s = dot(n, p)
        f = (p[0]-s*n[0], p[1]-s*n[1], p[2]-s*n[2])
        fl = math.sqrt(dot(f, f))
        if fl > 0:
            f = (f[0]/fl, f[1]/fl, f[2]/fl)
            if dot(cross(a, f), n) >= 0 and dot(cross(f, b), n) >= 0:
                return abs(math.asin(max(-1, min(1, s)))), f
    da, db = angle(p, a), angle(p, b)
    return (da, a) if da <= db else (db, b)

def rings(g):
    if g is None:
        return []
    polys = [g["coordinates"]] if g["type"] == "Polygon" else g["coordinates"] if g["type"] == "MultiPolygon" else []
    return [r for p in polys for r in p]

def segments(g):
    out = []
    for r in rings(g):
        u = [unit(p) for p in r]
        out.extend(zip(u, u[1:]))
    return out

def nearest(p, segs):
    best = (float("inf"), None)
    for a, b in segs:
        d = nearest_on_segment(p, a, b)
        if d[0] < best[0]:
            best = d
    return best

def main():
    inp = json.load(open(sys.argv[1]))["features"]
    out_list = json.load(open(sys.argv[2]))["features"]
    # Output features by id and name (a run that refused a feature leaves it out); a vertex
    # whose feature is missing is skipped.
    key = lambda f: json.dumps([f.get("id"), (f.get("properties") or {}).get("name")])
    by_key = {key(f): f for f in out_list}
    out = [by_key.get(key(f)) for f in inp]
    edges = {}
    for i, f in enumerate(inp):
        for r in rings(f["geometry"]):
            for a, b in zip(r, r[1:]):
                k = tuple(sorted([tuple(a), tuple(b)]))
                edges.setdefault(k, set()).add(i)
    ends = {}
    for (a, b), users in edges.items():
        if len(users) == 2:
            pair = tuple(sorted(users))
            for v in (a, b):
                ends[(pair, v)] = ends.get((pair, v), 0) + 1
    segs = {}
    gaps = []
    for ((i, j), v), n in ends.items():
        if n < 2 or out[i] is None or out[j] is None:
            continue
        for k in (i, j):
            if k not in segs:
                segs[k] = segments(out[k]["geometry"])
        p = unit(v)
        _, pa = nearest(p, segs[i])
        d, _ = nearest(pa, segs[j])
        gaps.append(d * R)
    gaps.sort()
    n = len(gaps)
    if n == 0:
        print("no shared vertices")
        return
    q = lambda x: gaps[min(n - 1, int(x * n))]
    print(f"{n} shared vertices: median {q(0.5):.3f} m, p95 {q(0.95):.3f} m, max {gaps[-1]:.3f} m, "
          f"{100.0 * sum(g > 10 for g in gaps) / n:.1f}% over 10 m")

main()
