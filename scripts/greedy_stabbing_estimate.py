#!/usr/bin/env python3
"""An estimate, not spherefit's fitter: how many vertices a greedy, linear-time polyline with
free vertices needs against the tolerance fitter's (see docs/speed.md, fifth session).

Greedy ordered stabbing: from the current vertex v (a data point at the start), the longest run
of following points that one great circle from v passes within EPS of, in order (a point's foot
on it never more than EPS behind the furthest foot so far; the line's last point hit exactly);
the next vertex is the run's furthest foot on the middle direction of the feasible wedge.
Directions and distances are taken in v's gnomonic plane (great circles are straight lines
there; at these tolerances the distortion is below 1e-4 of EPS). Not certified: the count is
an estimate of what such a fitter would store (a sampled Hausdorff check of every 7th ring
under 400 points found EPS, docs/speed.md), not a checked curve.

  python3 scripts/greedy_stabbing_estimate.py T_METRES EPS_SHARE LINES.geojson FITTED.geojson

LINES.geojson: closed LineStrings (scripts/speed_bench.sh's land outlines); FITTED.geojson:
spherefit's output for them at T (its properties.fit.control_points are compared).
examples/greedy_estimate.rs is the same loop in Rust, timed.
"""
import json, math, sys

R = 6371008.8


def unit(lon, lat):
    lo, la = math.radians(lon), math.radians(lat)
    return (math.cos(la) * math.cos(lo), math.cos(la) * math.sin(lo), math.sin(la))


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def normed(a):
    n = math.sqrt(dot(a, a))
    return (a[0] / n, a[1] / n, a[2] / n)


def frame(v):
    a = (1.0, 0.0, 0.0) if abs(v[0]) < 0.9 else (0.0, 1.0, 0.0)
    e1 = normed(cross(v, a))
    return e1, cross(v, e1)


def plane(q, v, e1, e2):
    c = dot(q, v)
    return (dot(q, e1) / c, dot(q, e2) / c) if c > 0.5 else None


def run_from(pts, i, end, v, e1, e2, eps):
    """The run i..j (exclusive, j <= end) stabbed from v in order, and the chosen direction."""
    n = len(pts)
    lo, hi, base = -math.inf, math.inf, None
    j = i
    while j < end:
        xy = plane(pts[j], v, e1, e2)
        if xy is None:
            break
        r = math.hypot(*xy)
        # The last point is the line's end (a ring's seam): hit exactly.
        reach = 0.0 if j == n - 1 else eps
        if r > reach:
            phi = math.atan2(xy[1], xy[0])
            a = math.asin(min(1.0, reach / r))
            if base is None:
                base = phi
            d = (phi - base + math.pi) % (2 * math.pi) - math.pi
            nlo, nhi = max(lo, d - a), min(hi, d + a)
            if nlo > nhi:
                break
            lo, hi = nlo, nhi
        j += 1
    psi = 0.0 if base is None else base + (0.0 if lo == -math.inf else 0.5 * (lo + hi))
    return j, (math.cos(psi), math.sin(psi))


def ordered_until(pts, i, j, v, e1, e2, u, eps):
    """The first index in i..j whose foot is more than eps behind the reach (j when none)."""
    reach = 0.0
    for m in range(i, j):
        x, y = plane(pts[m], v, e1, e2)
        t = x * u[0] + y * u[1]
        if t < reach and math.hypot(x - reach * u[0], y - reach * u[1]) > eps:
            return m
        reach = max(reach, t)
    return j


def far_foot(pts, i, j, v, e1, e2, u):
    """The furthest foot along direction u of points i..j: where the segment ends (a point
    behind it is within eps of it, see ordered_until)."""
    t = 0.0
    for m in range(i, j):
        x, y = plane(pts[m], v, e1, e2)
        t = max(t, x * u[0] + y * u[1])
    return t


def greedy(pts, eps):
    n = len(pts)
    v, count, i = pts[0], 1, 1
    while i < n:
        e1, e2 = frame(v)
        j, u = run_from(pts, i, n, v, e1, e2, eps)
        while j > i:
            m = ordered_until(pts, i, j, v, e1, e2, u, eps)
            if m == j:
                break
            j, u = run_from(pts, i, m, v, e1, e2, eps)
        if j == i:
            v, count, i = pts[i], count + 1, i + 1
            continue
        if j >= n:
            # The run ends at the last point itself (hit exactly, see run_from).
            return count + 1
        t = far_foot(pts, i, j, v, e1, e2, u)
        g = tuple(v[k] + t * (u[0] * e1[k] + u[1] * e2[k]) for k in range(3))
        v, count, i = normed(g), count + 1, j
    return count


def main():
    T, share = float(sys.argv[1]), float(sys.argv[2])
    lines = json.load(open(sys.argv[3]))["features"]
    fitted = json.load(open(sys.argv[4]))["features"]
    eps = share * T / R
    greedy_total = fitted_total = rings = 0
    for f, o in zip(lines, fitted):
        cs = f["geometry"]["coordinates"]
        pts = [unit(*p[:2]) for p in cs]
        greedy_total += greedy(pts, eps)
        fitted_total += o["properties"]["fit"]["control_points"]
        rings += 1
    print(f"T = {T:g} m, EPS = {share:g} T: {rings} lines; greedy vertices {greedy_total:,} "
          f"(~{2 * greedy_total + rings:,} numbers); the fitter's control points "
          f"{fitted_total:,} (~{2 * fitted_total + rings:,})")


if __name__ == "__main__":
    main()
