"""Wall time of one fit of the Natural Earth 10m land outlines: in-process, the CLI, and Dask
with 1 and 2 worker processes (1 thread each). Run through python/bench/land.sh.

Usage: python land.py LAND_GEOJSON SPHEREFIT_BIN [--tolerance-m M] [--repeat N]
Prints a Markdown table (best of N runs per mode) and checks that every mode gives the same fit.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import geopandas as gpd

import spherefit


def best(f, repeat):
    times, result = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        result = f()
        times.append(time.perf_counter() - t)
    return min(times), result


def in_process(path, options, repeat, threads):
    """Runs the in-process fit in a child with RAYON_NUM_THREADS set (the pool is per process)."""
    code = (
        "import json, sys, time, geopandas as gpd, spherefit\n"
        f"gdf = gpd.read_file({path!r}, engine='pyogrio') if False else gpd.GeoDataFrame.from_features(json.load(open({path!r}))['features'], crs=4326)\n"
        "ts = []\n"
        f"for _ in range({repeat}):\n"
        "    t = time.perf_counter(); out = spherefit.fit(gdf, **json.loads(sys.argv[1])); ts.append(time.perf_counter() - t)\n"
        "print(json.dumps({'seconds': min(ts), 'fits': out['fit'].tolist()}))\n"
    )
    env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
    r = subprocess.run([sys.executable, "-c", code, json.dumps(options)], env=env, capture_output=True, text=True, check=True)
    doc = json.loads(r.stdout)
    return doc["seconds"], doc["fits"]


def cli(path, binary, options, repeat):
    args = [binary, "fit", "-q", path]
    if options.get("tolerance_m") is not None:
        args += ["--tolerance-m", str(options["tolerance_m"])]
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "out.geojson")
        seconds, _ = best(lambda: subprocess.run([*args, "-o", out], check=True), repeat)
        fits = [json.dumps(f["properties"]["fit"], separators=(",", ":"), sort_keys=True) for f in json.load(open(out))["features"]]
    return seconds, fits


def on_dask(gdf, workers, options, repeat):
    import dask_geopandas
    from distributed import Client, LocalCluster

    with LocalCluster(
        n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
        scheduler_port=18602 + workers, dashboard_address=None, worker_port="18630:18639",
        port="18650:18659", env={"RAYON_NUM_THREADS": "1"},
    ) as cluster, Client(cluster):
        ddf = dask_geopandas.from_geopandas(gdf, npartitions=8)
        return best(lambda: spherefit.dask.fit(ddf, **options).compute()["fit"].tolist(), repeat)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("land")
    ap.add_argument("binary")
    ap.add_argument("--tolerance-m", type=float, default=None)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    import spherefit.dask  # noqa: F401

    options = {} if a.tolerance_m is None else {"tolerance_m": a.tolerance_m}
    gdf = gpd.GeoDataFrame.from_features(json.load(open(a.land))["features"], crs=4326)
    points = int(gdf.geometry.count_coordinates().sum())
    rows = []
    base = None
    for name, run in [
        ("in-process, 2 threads", lambda: in_process(a.land, options, a.repeat, 2)),
        ("in-process, 1 thread", lambda: in_process(a.land, options, a.repeat, 1)),
        ("CLI `spherefit fit`, 2 threads (GeoJSON in and out)", lambda: cli(a.land, a.binary, options, a.repeat)),
        ("Dask, 1 worker process x 1 thread, 8 partitions", lambda: on_dask(gdf, 1, options, a.repeat)),
        ("Dask, 2 worker processes x 1 thread, 8 partitions", lambda: on_dask(gdf, 2, options, a.repeat)),
    ]:
        seconds, fits = run()
        canon = [json.dumps(json.loads(f), separators=(",", ":"), sort_keys=True) for f in fits]
        if base is None:
            base = canon
        assert canon == base, f"{name}: a different fit"
        rows.append((name, seconds))
    print(f"{len(gdf)} polygons, {points} points, options {options or 'default'}, best of {a.repeat}, load {os.getloadavg()[0]:.1f}")
    print("| run | wall time | points/s |")
    print("|---|---:|---:|")
    for name, s in rows:
        print(f"| {name} | {s:.2f} s | {points / s:,.0f} |")


if __name__ == "__main__":
    main()
