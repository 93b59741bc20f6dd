#!/usr/bin/env python3
"""Euclidean baseline for the fast-solver bench: scipy's make_lsq_spline on the same points.

Reads the files `examples/fit_large.rs --dump DIR` wrote (parameters t, points xyz, knots, all
little-endian f64) and fits x, y and z as cubic least-squares splines of t with the same knots:
the Euclidean least-squares fit of the same points that spherefit fits on the sphere. Prints
one JSON line with the wall time of the fit and its geodesic RMS / max error after projecting
the curve back onto the sphere. Run through benches/solver_compare.sh.
"""
import json
import sys
import time

import numpy as np
from scipy.interpolate import make_lsq_spline

d = sys.argv[1]
t = np.fromfile(f"{d}/t.f64", dtype="<f8")
xyz = np.fromfile(f"{d}/xyz.f64", dtype="<f8").reshape(-1, 3)
knots = np.fromfile(f"{d}/knots.f64", dtype="<f8")

# make_lsq_spline needs strictly increasing x: repeated parameters (repeated points) are merged.
keep = np.concatenate(([True], np.diff(t) > 0))
start = time.perf_counter()
spl = make_lsq_spline(t[keep], xyz[keep], knots, k=3)
seconds = time.perf_counter() - start
c = spl(t)
c /= np.linalg.norm(c, axis=1)[:, None]
ang = 2 * np.arctan2(np.linalg.norm(xyz - c, axis=1), np.linalg.norm(xyz + c, axis=1))
print(json.dumps({
    "solver": "scipy make_lsq_spline (Euclidean, x/y/z)",
    "points": int(len(t)), "control_points": int(len(knots) - 4),
    "seconds": round(seconds, 3),
    "rms_error_rad": float(np.sqrt(np.mean(ang ** 2))), "max_error_rad": float(ang.max()),
}))
