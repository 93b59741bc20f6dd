"""Compact curves (``carry="spline"``, #30) in Python: ``evaluate`` decodes them to the points
the CLI decodes and the JSON spline of the same fit gives, refuses hostile ones with
``SpherefitError``, and they travel through GeoParquet as the ``fit`` column."""

import base64
import json
import struct

import geopandas as gpd
import numpy as np
import pytest
import shapely

import spherefit
from conftest import FIXTURES, run_cli

BORDER = FIXTURES / "us_mexico_border_natural_earth.geojson"


def coords(g):
    return shapely.get_coordinates(g)


def test_evaluate_decodes_compact_curves_to_the_cli_and_json_spline_points(border, tmp_path):
    common = ["--tolerance-m", "100", "--precision", "4"]
    compact = run_cli("fit", "-q", *common, "--carry", "spline", BORDER)
    both = run_cli("fit", "-q", *common, "--carry", "both", BORDER)
    paths = {}
    for name, doc in [("spline", compact), ("both", both)]:
        paths[name] = tmp_path / f"{name}.geojson"
        paths[name].write_text(json.dumps(doc))
    evaluate = ["evaluate", "-q", "--samples", "400", "--precision", "9"]
    cli_compact = run_cli(*evaluate, paths["spline"])["features"]
    cli_json = run_cli(*evaluate, paths["both"])["features"]
    # The CLI's fit reports, compact curve inside, as a table would hold them.
    fits = [f["properties"]["fit"] for f in compact["features"]]
    assert all(isinstance(f["spline"], str) for f in fits)
    out = spherefit.evaluate(fits, samples=400, precision=9)
    # The same fit made in Python: its `fit` column holds the same compact curves.
    mine = spherefit.fit(border, tolerance_m=100, precision=4, carry="spline")
    assert mine.geometry.isna().all()
    assert [json.loads(t)["spline"] for t in mine["fit"]] == [f["spline"] for f in fits]
    drawn = spherefit.evaluate(mine, samples=400, precision=9)
    for i, f in enumerate(fits):
        want = np.array(cli_json[i]["geometry"]["coordinates"])
        assert want.shape == (400, 2)
        for got in (coords(out.geometry.iloc[i]), coords(drawn.geometry.iloc[i])):
            np.testing.assert_array_equal(got, np.array(cli_compact[i]["geometry"]["coordinates"]))
            # Lossless: the JSON spline's points to the output's 1e-9 degrees.
            assert np.abs(got - want).max() <= 1e-9
        assert out["output_points"].iloc[i] == 400
        assert f["two_way_distance_m"] <= 100


def _varint(v):
    out = bytearray()
    while True:
        b = v & 0x7F
        v >>= 7
        if v:
            out.append(b | 0x80)
        else:
            out.append(b)
            return bytes(out)


def _bits(x):
    return struct.unpack("<Q", struct.pack("<d", x))[0]


def test_hostile_compact_curves_raise_spherefit_error_naming_the_byte():
    fitted = run_cli("fit", "-q", "--tolerance-m", "100", "--carry", "spline", BORDER)
    good = base64.b64decode(fitted["features"][0]["properties"]["fit"]["spline"])
    assert good[0] == 1
    half = _bits(0.5)
    cases = {
        "wrong version": (bytes([2]) + good[1:], "version 2 at byte 0"),
        "counts beyond the bytes": (bytes([1, 3, 1]) + _varint(5000) + b"\0", "promises"),
        "truncated": (good[:5], "bytes left"),
        "varint over 64 bits": (bytes([1, 3, 1, 3, 0]) + b"\xff" * 11 + b"\0" * 6, "longer than 64 bits"),
        "decreasing knots": (
            bytes([1, 3, 1, 3, 5]) + _varint(half) + _varint(0x8000000000000001 - half) + b"\0" * 9,
            "knot 1 at byte",
        ),
        "trailing bytes": (good + b"\0", "after the last control point"),
    }
    for what, (stream, message) in cases.items():
        text = base64.b64encode(stream).decode()
        with pytest.raises(spherefit.SpherefitError, match=message) as e:
            spherefit.evaluate([None, {"spline": text}])
        assert e.value.problem == "invalid-spline", what
        assert (e.value.index, e.value.pointer) == (1, "/spline"), what
        assert "byte" in str(e.value), what
    with pytest.raises(spherefit.SpherefitError, match="not base64: character 1") as e:
        spherefit.evaluate([{"spline": "A!=="}])
    assert e.value.problem == "invalid-spline"


def test_compact_curves_as_a_geoparquet_column_read_back_to_geometries(border, tmp_path):
    src, dst = tmp_path / "in.parquet", tmp_path / "curves.parquet"
    border.to_parquet(src)
    written = spherefit.fit_file(src, dst, tolerance_m=100, precision=4, carry="spline")
    back = gpd.read_parquet(dst)
    assert back.geometry.isna().all()
    assert list(back["name"]) == list(border["name"])
    compact = [json.loads(t)["spline"] for t in back["fit"]]
    assert all(isinstance(c, str) and c.startswith("AQ") for c in compact)
    assert list(back["fit"]) == list(written["fit"])
    drawn = spherefit.evaluate(back, precision=4)
    full = spherefit.fit(border, tolerance_m=100, precision=4)
    for i in range(len(border)):
        # The geometry the same fit writes with carry="both".
        assert shapely.equals_exact(drawn.geometry.iloc[i], full.geometry.iloc[i], tolerance=0)
        assert drawn["name"].iloc[i] == border["name"].iloc[i]
    # The column is small: under a third of the WKB of the geometry it stands for (3.3x here).
    assert sum(map(len, compact)) * 3 < sum(len(shapely.to_wkb(g)) for g in full.geometry)
