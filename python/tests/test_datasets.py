"""Whole datasets back whole: Natural Earth's 110m countries as GIS packages ship them.

pyogrio's `naturalearth_lowres` shapefile (the file geopandas shipped before 1.0) cuts Fiji and
Russia at ±180 and closes Antarctica along the South Pole. Converted by GDAL
(`fixtures/naturalearth_lowres_gdal.geojson`), `spherefit.fit` gives every row back, every ring
valid for shapely, and the same geometries as the CLI on the same data. Read straight from the
shapefile, Russia holds a longitude of 180.00000000000006 (floating-point noise past the line,
which GDAL's GeoJSON writer rounds away): refused with its row and position, as every
coordinate out of range is.
"""

import json
from pathlib import Path

import geopandas as gpd
import pyogrio
import pytest
import shapely

import spherefit
from conftest import FIXTURES, run_cli

SHAPEFILE = (
    Path(pyogrio.__file__).parent
    / "tests"
    / "fixtures"
    / "naturalearth_lowres"
    / "naturalearth_lowres.shp"
)


@pytest.fixture(scope="module")
def countries():
    return gpd.read_file(FIXTURES / "naturalearth_lowres_gdal.geojson")


def test_the_shapefile_as_shipped_is_refused_where_its_noise_is():
    gdf = gpd.read_file(SHAPEFILE)
    assert len(gdf) == 177 and gdf["name"].iloc[18] == "Russia"
    with pytest.raises(spherefit.SpherefitError, match=r"feature 18 .*180\.00000000000006"):
        spherefit.fit(gdf, tolerance_m=1000)


@pytest.mark.parametrize("topology", ["per-feature", "shared"])
@pytest.mark.parametrize("tolerance_m", [100, 1000])
def test_natural_earth_countries_from_a_shapefile_come_back_whole(
    countries, tolerance_m, topology
):
    gdf = countries
    assert len(gdf) == 177
    out = spherefit.fit(gdf, tolerance_m=tolerance_m, topology=topology)
    assert len(out) == len(gdf)
    assert list(out.index) == list(gdf.index)
    assert out["name"].tolist() == gdf["name"].tolist()
    assert out["tolerance_met"].all()
    assert not out.geometry.isna().any() and not out.geometry.is_empty.any()
    # Valid wherever the input is (Sudan's input ring touches itself).
    invalid_in = set(gdf["name"][~gdf.geometry.is_valid])
    invalid_out = set(out["name"][~out.geometry.is_valid])
    assert invalid_in == {"Sudan"}
    assert invalid_out <= invalid_in, {
        n: shapely.is_valid_reason(out.geometry[out["name"] == n].iloc[0])
        for n in invalid_out - invalid_in
    }
    # Antarctica stays one region round the South Pole with its area.
    ant = json.loads(out["fit"][out["name"] == "Antarctica"].iloc[0])
    assert abs(ant["area_change"]) < 1e-4 and ant["area_m2"] > 1.2e13
    assert out.geometry[out["name"] == "Antarctica"].iloc[0].bounds[1] == -90.0
    # The same geometries as the CLI on the same file.
    path = FIXTURES / "naturalearth_lowres_gdal.geojson"
    cli = run_cli("fit", "--tolerance-m", tolerance_m, "--topology", topology, "-q", path)[
        "features"
    ]
    assert len(cli) == len(out)
    for i, f in enumerate(cli):
        got = out.geometry.iloc[i]
        want = shapely.geometry.shape(f["geometry"])
        assert shapely.equals_exact(got, want, tolerance=1e-9), (i, f["properties"]["name"])
