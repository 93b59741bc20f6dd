"""spherefit.fit / interpolate / evaluate / fit_file on shapely and geopandas input."""

import json

import geopandas as gpd
import numpy as np
import pandas as pd
import pytest
import shapely
from shapely.geometry import shape

import spherefit
from conftest import FIXTURES, features, frame, run_cli


def same_geometry(a, b):
    """Exactly the same geometry (type, parts, dimensions and every coordinate)."""
    return shapely.to_wkb(a, output_dimension=3) == shapely.to_wkb(b, output_dimension=3)


def same_report(py, cli):
    """The Python report equals the CLI's, except that where the CLI writes a degree-1 spline
    once (``"control_points": "geometry"``, knots left out when uniform) Python's column keeps
    them, since ``evaluate`` reads that column without the geometry (the geometry itself is
    compared apart)."""
    if isinstance(cli, dict) and cli.get("control_points") == "geometry":
        return (
            isinstance(py, dict)
            and py.get("degree") == 1
            and isinstance(py.get("control_points"), list)
            and all(same_report(py.get(k), v) for k, v in cli.items() if k not in ("control_points", "knots"))
        )
    if isinstance(cli, dict):
        return isinstance(py, dict) and py.keys() == cli.keys() and all(same_report(py[k], cli[k]) for k in cli)
    if isinstance(cli, list):
        return isinstance(py, list) and len(py) == len(cli) and all(same_report(a, b) for a, b in zip(py, cli))
    return py == cli


def assert_equals_cli(out, cli_features, key):
    assert len(out) == len(cli_features)
    for i, f in enumerate(cli_features):
        props = f["properties"] or {}
        if key in props:
            assert same_report(json.loads(out[key].iloc[i]), props[key]), i
            assert same_geometry(out.geometry.iloc[i], shape(f["geometry"])), i
            for col in spherefit.output_columns(key if key == "fit" else "interpolate"):
                if col in props[key] and col != key:
                    assert out[col].iloc[i] == props[key][col], (i, col)
        else:
            assert out[key].iloc[i] is None
            assert same_geometry(out.geometry.iloc[i], shape(f["geometry"])), i


# -- fit ------------------------------------------------------------------------------------


def test_fit_geodataframe_round_trip_keeps_columns_index_and_crs(border):
    gdf = border.set_index(pd.Index(["a", "b", "c"], name="key"))
    out = spherefit.fit(gdf, control_points=12)
    assert isinstance(out, gpd.GeoDataFrame)
    assert list(out.index) == ["a", "b", "c"] and out.index.name == "key"
    assert out.crs == gdf.crs
    for col in gdf.columns:
        if col != "geometry":
            assert out[col].tolist() == gdf[col].tolist(), col
    assert set(spherefit.FIT_COLUMNS) <= set(out.columns) and "fit" in out.columns
    assert out["control_points"].tolist() == [12, 12, 12]
    assert (out["max_error_m"] > 0).all()
    assert out.geometry.geom_type.tolist() == ["LineString"] * 3
    spline = json.loads(out["fit"].iloc[2])["spline"]
    assert len(spline["control_points"]) == 12 and spline["degree"] == 3
    assert gdf.geometry.iloc[0] is not out.geometry.iloc[0]  # the input is not modified
    assert border.geometry.iloc[0].equals(gdf.geometry.iloc[0])
    # Another geometry column name and a GeoSeries keep their names, index and CRS too.
    renamed = spherefit.fit(gdf.rename_geometry("line"), control_points=12)
    assert renamed.geometry.name == "line" and "geometry" not in renamed.columns
    assert renamed["fit"].tolist() == out["fit"].tolist()
    series = spherefit.fit(gdf.geometry, control_points=12)
    assert list(series.index) == ["a", "b", "c"] and series.crs == gdf.crs


def test_fit_equals_cli_on_the_border(border):
    cli = run_cli("fit", "-q", FIXTURES / "us_mexico_border_natural_earth.geojson")
    assert_equals_cli(spherefit.fit(border), cli["features"], "fit")


def test_fit_to_tolerance_equals_cli_on_gps_tracks(tracks):
    path = FIXTURES / "gps_tracks_slovenia_gpxpy.geojson"
    cli = run_cli("fit", "-q", "--tolerance-m", "10", path)
    out = spherefit.fit(tracks, tolerance_m=10)
    assert_equals_cli(out, cli["features"], "fit")
    assert out["tolerance_met"].all()
    assert (out["max_error_m"] <= 10).all()
    assert set(spherefit.TOLERANCE_COLUMNS) <= set(out.columns)


def test_fit_equals_cli_on_antimeridian_altitude_point_parts_ring_and_pole(batch):
    path = FIXTURES / "batch_tracks.geojsons"
    cli = run_cli("fit", "-q", "--output-format", "geojson", "--samples", "40", path)
    out = spherefit.fit(batch, samples=40)
    assert_equals_cli(out, cli["features"], "fit")
    types = out.geometry.geom_type.tolist()
    assert types[1] == "MultiLineString" and out.geometry.iloc[1].has_z  # cut at 180, altitude
    assert types[2] == "Point" and pd.isna(out["max_error_m"].iloc[2])  # passes through
    assert types[4] == "Polygon"


def test_fit_with_options_equals_cli(border):
    path = FIXTURES / "us_mexico_border_natural_earth.geojson"
    cli = run_cli(
        "fit", "-q", "-n", "9", "--degree", "2", "--knots", "uniform", "--solver",
        "gauss-newton", "--spacing-m", "20000", "--precision", "5", path,
    )
    out = spherefit.fit(
        border, control_points=9, degree=2, knots="uniform", solver="gauss-newton",
        spacing_m=20000, precision=5,
    )
    assert_equals_cli(out, cli["features"], "fit")


def test_fit_shapely_array_and_geoseries(border):
    arr = np.asarray(border.geometry.values, dtype=object)
    a = spherefit.fit(arr)
    s = spherefit.fit(border.geometry)
    g = spherefit.fit(border)
    assert isinstance(a, gpd.GeoDataFrame) and list(a.index) == [0, 1, 2]
    assert s.crs == border.crs
    for i in range(3):
        assert same_geometry(a.geometry.iloc[i], g.geometry.iloc[i])
        assert a["fit"].iloc[i] == s["fit"].iloc[i] == g["fit"].iloc[i]
    lst = spherefit.fit(list(arr) + [None])
    assert lst.geometry.iloc[3] is None and lst["fit"].iloc[3] is None
    empty = spherefit.fit(border.iloc[:0])
    assert len(empty) == 0 and "fit" in empty.columns


def test_fit_bad_coordinate_names_feature_and_coordinate():
    geoms = [shapely.LineString([(0, 0), (1, 1), (2, 2)]), shapely.LineString([(0, 0), (1, 95), (2, 0)])]
    with pytest.raises(spherefit.SpherefitError) as e:
        spherefit.fit(geoms)
    assert isinstance(e.value, ValueError)
    assert e.value.index == 1 and e.value.pointer == "/coordinates/1/1"
    assert e.value.problem == "invalid-coordinate"
    assert str(e.value).startswith("feature 1 at /coordinates/1/1: latitude 95")


def test_fit_bad_inputs():
    line = shapely.LineString([(0, 0), (1, 1), (2, 0), (3, 1)])
    with np.errstate(invalid="ignore"):
        nan_line = shapely.LineString([(0, 0), (1, 1), (np.nan, 0)])
    with pytest.raises(spherefit.SpherefitError, match="feature 0 at /coordinates/2/0: NaN is not a finite number"):
        spherefit.fit([nan_line])
    with pytest.raises(spherefit.SpherefitError, match="1 distinct position") as e:
        spherefit.fit([line, shapely.LineString([(5, 5), (5, 5)])])
    assert e.value.index == 1 and e.value.problem == "too-few-points"
    with pytest.raises(spherefit.SpherefitError, match="^degree: degree 9: use 1 to 5") as e:
        spherefit.fit([line], degree=9)
    assert e.value.index is None and e.value.problem == "invalid-option"
    with pytest.raises(spherefit.SpherefitError, match="^tolerance_m: -1"):
        spherefit.fit([line], tolerance_m=-1)
    with pytest.raises(spherefit.SpherefitError, match="^tolerance_m: tolerance_m excludes control_points") as e:
        spherefit.fit([line], tolerance_m=5, control_points=4)
    assert e.value.problem == "conflicting-options"
    with pytest.raises(spherefit.SpherefitError, match="^topology: .* give tolerance_m too"):
        spherefit.fit([line], topology="shared")
    with pytest.raises(spherefit.SpherefitError, match="^time_property: time_property excludes parameterization chord"):
        spherefit.fit([line], parameterization="chord", time_property="t")
    with pytest.raises(spherefit.SpherefitError, match="^knots: "):
        spherefit.fit([line], knots="nope")
    with pytest.raises(spherefit.SpherefitError, match="^samples: 1 samples"):
        spherefit.fit([line], samples=1)
    with pytest.raises(spherefit.SpherefitError, match="feature 1: expected a shapely geometry"):
        spherefit.fit([line, "LINESTRING (0 0, 1 1)"])
    with pytest.raises(spherefit.SpherefitError, match="got one geometry"):
        spherefit.fit(line)
    projected = gpd.GeoDataFrame(geometry=[line], crs="EPSG:3857")
    with pytest.raises(spherefit.SpherefitError, match="not a geographic CRS"):
        spherefit.fit(projected)
    with pytest.raises(spherefit.SpherefitError, match="M values"):
        spherefit.fit([shapely.from_wkt("LINESTRING M (0 0 1, 1 1 2, 2 0 3, 3 1 4)")])


def test_fit_shared_topology_equals_cli(tmp_path):
    path = FIXTURES / "coverage_us_states.geojson"
    cli = run_cli("fit", "-q", "--topology", "shared", "--tolerance-m", "5000", path)
    gdf = frame(path)
    out = spherefit.fit(gdf, topology="shared", tolerance_m=5000)
    assert_equals_cli(out, cli["features"], "fit")
    # The coverage's arcs come back with it, as the CLI's collection member.
    assert out.attrs["topology"] == cli["topology"]
    assert out.attrs["topology"]["shared_arcs"] > 0
    assert len(out.attrs["topology"]["arcs"]) == out.attrs["topology"]["arc_count"]


def test_fit_drop_small_rings_equals_cli_in_both_topologies():
    path = FIXTURES / "small_rings.geojson"
    # The fixture's third feature (a MultiPoint of mixed dimensions) has no WKB form.
    gdf = frame(path).iloc[:2]
    for topology in ["per-feature", "shared"]:
        cli = run_cli(
            "fit", "-q", "--tolerance-m", "1000", "--topology", topology, "--drop-small-rings", path
        )
        out = spherefit.fit(gdf, tolerance_m=1000, topology=topology, drop_small_rings=True)
        features = cli["features"][:2]
        if topology == "per-feature":
            # Per row, pointers are into the row's geometry, as in every error of spherefit.fit;
            # a coverage's are into the document the rows make, as its arcs are.
            for i, f in enumerate(features):
                for k in ("kept_rings", "dropped_rings"):
                    prefix = f"/features/{i}/geometry"
                    f["properties"]["fit"][k] = [p[len(prefix):] for p in f["properties"]["fit"][k]]
        assert_equals_cli(out, features, "fit")
        dropped = json.loads(out["fit"].iloc[1])["dropped_rings"]
        expected = "/coordinates/1" if topology == "per-feature" else "/features/1/geometry/coordinates/1"
        assert dropped == [expected], topology
        kept = spherefit.fit(gdf, tolerance_m=1000, topology=topology)
        assert "dropped_rings" not in json.loads(kept["fit"].iloc[1]), topology


def timed_tracks():
    """The fixture's tracks with usable times (unix seconds in ``timestamps_unix_s``)."""
    doc = json.loads((FIXTURES / "gps_tracks_slovenia_gpxpy.geojson").read_text())
    doc["features"] = [
        f
        for f in doc["features"]
        if isinstance(f["properties"].get("timestamps_unix_s"), list)
        and all(b > a for a, b in zip(f["properties"]["timestamps_unix_s"], f["properties"]["timestamps_unix_s"][1:]))
    ]
    assert len(doc["features"]) == 6
    return doc


def test_fit_in_time_and_evaluate_at_equal_cli(tmp_path):
    doc = timed_tracks()
    path = tmp_path / "timed.geojson"
    path.write_text(json.dumps(doc))
    cli = run_cli("fit", "-q", "--time-property", "timestamps_unix_s", "--tolerance-m", "10", path)
    gdf = gpd.GeoDataFrame.from_features(doc["features"], crs="EPSG:4326")
    out = spherefit.fit(gdf, time_property="timestamps_unix_s", tolerance_m=10)
    assert_equals_cli(out, cli["features"], "fit")
    assert json.loads(out["fit"].iloc[0])["parameterization"] == "time"
    # Positions, speed and heading at times, as `spherefit evaluate --at`.
    t0 = doc["features"][0]["properties"]["timestamps_unix_s"][0]
    at = [t0 + 60, t0 + 120.5]
    first_fit = tmp_path / "first.geojson"
    first_fit.write_text(json.dumps({"type": "FeatureCollection", "features": cli["features"][:1]}))
    cli_at = run_cli("evaluate", "-q", "--at", ",".join(str(t) for t in at), first_fit)
    ev = spherefit.evaluate(out.iloc[:1], at=at)
    first = cli_at["features"][0]
    assert json.loads(ev["evaluation"].iloc[0]) == first["properties"]["evaluation"]
    assert same_geometry(ev.geometry.iloc[0], shape(first["geometry"]))
    assert ev.geometry.iloc[0].geom_type == "MultiPoint"
    # spacing_s: a curve in time sampled every 30 s, as the CLI does.
    fitted = tmp_path / "fitted.geojson"
    fitted.write_text(json.dumps(cli))
    cli_s = run_cli("evaluate", "-q", "--spacing-s", "30", fitted)
    ev_s = spherefit.evaluate(out, spacing_s=30)
    assert_equals_cli(ev_s, cli_s["features"], "evaluation")
    with pytest.raises(spherefit.SpherefitError, match="^at: "):
        spherefit.evaluate(out.iloc[:1], at="yesterday")


# -- interpolate ------------------------------------------------------------------------------


def test_interpolate_equals_cli(batch):
    path = FIXTURES / "batch_tracks.geojsons"
    cli = run_cli("interpolate", "-q", "--output-format", "geojson", "--beta2", "2", path)
    out = spherefit.interpolate(batch, beta2=2)
    assert_equals_cli(out, cli["features"], "interpolation")
    assert set(spherefit.INTERPOLATE_COLUMNS) <= set(out.columns)


def test_interpolate_bad_input():
    with pytest.raises(spherefit.SpherefitError, match="^beta1: "):
        spherefit.interpolate([shapely.LineString([(0, 0), (1, 1), (2, 0)])], beta1=0)
    with pytest.raises(spherefit.SpherefitError) as e:
        spherefit.interpolate([shapely.LineString([(0, 0), (1, 1)]), shapely.LineString([(0, 0), (200, 1)])])
    assert e.value.index == 1 and e.value.pointer == "/coordinates/1/0"


# -- evaluate ---------------------------------------------------------------------------------


def test_evaluate_equals_cli(batch, tmp_path):
    path = FIXTURES / "batch_tracks.geojsons"
    fitted_cli = run_cli("fit", "-q", "--output-format", "geojson", path)
    p = tmp_path / "fitted.geojson"
    p.write_text(json.dumps(fitted_cli))
    cli = run_cli("evaluate", "-q", "--samples", "33", p)
    fitted = spherefit.fit(batch)
    out = spherefit.evaluate(fitted, samples=33)
    assert_equals_cli(out, cli["features"], "evaluation")
    assert "fit" in out.columns and set(spherefit.EVALUATE_COLUMNS) <= set(out.columns)
    # From the JSON alone (text or dicts), as stored in a table.
    docs = [None if s is None else json.loads(s) for s in fitted["fit"]]
    alone = spherefit.evaluate(docs, samples=33)
    for i in range(len(docs)):
        if docs[i] is not None:
            assert same_geometry(alone.geometry.iloc[i], out.geometry.iloc[i])
    interp = spherefit.interpolate(batch)
    again = spherefit.evaluate(interp, spacing_m=5000)
    assert again["output_points"].iloc[0] > 2


def test_evaluate_bad_input():
    with pytest.raises(spherefit.SpherefitError, match="feature 1: the fit JSON is not valid JSON"):
        spherefit.evaluate([None, "{not json"])
    with pytest.raises(spherefit.SpherefitError, match="feature 0 at /spline") as e:
        spherefit.evaluate([{"spline": {"degree": 3, "knots": [0, 1], "control_points": [[0, 0]]}}])
    assert e.value.index == 0 and e.value.problem == "invalid-spline"
    with pytest.raises(spherefit.SpherefitError, match="must be an object"):
        spherefit.evaluate(["5"])
    with pytest.raises(spherefit.SpherefitError, match="no 'fit' column"):
        spherefit.evaluate(gpd.GeoDataFrame(geometry=[shapely.Point(0, 0)]), key="fit")


# -- GeoParquet -------------------------------------------------------------------------------


def test_fit_file_geoparquet_round_trip(tracks, tmp_path):
    src, dst = tmp_path / "in.parquet", tmp_path / "out.parquet"
    tracks.to_parquet(src)
    out = spherefit.fit_file(src, dst, tolerance_m=10)
    back = gpd.read_parquet(dst)
    assert back.crs == tracks.crs
    assert list(back.columns) == list(out.columns)
    direct = spherefit.fit(tracks, tolerance_m=10)
    for i in range(len(tracks)):
        assert same_geometry(back.geometry.iloc[i], direct.geometry.iloc[i])
        assert back["fit"].iloc[i] == direct["fit"].iloc[i]
        assert back["name"].iloc[i] == tracks["name"].iloc[i]
    assert back["stored_numbers"].tolist() == direct["stored_numbers"].tolist()


def test_fit_file_missing_input(tmp_path):
    with pytest.raises(Exception):
        spherefit.fit_file(tmp_path / "missing.parquet", tmp_path / "out.parquet")
