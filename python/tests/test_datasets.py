"""Whole datasets back whole: Natural Earth's 110m countries as GIS packages ship them.

pyogrio's `naturalearth_lowres` shapefile (the file geopandas shipped before 1.0) cuts Fiji and
Russia at ±180 and closes Antarctica along the South Pole. `spherefit.fit` gives every row
back, every ring valid for shapely, and the same geometries as the CLI on the same data.
"""

import json
from pathlib import Path

import geopandas as gpd
import pyogrio
import pytest
import shapely

import spherefit
from conftest import run_cli

SHAPEFILE = (
    Path(pyogrio.__file__).parent
    / "tests"
    / "fixtures"
    / "naturalearth_lowres"
    / "naturalearth_lowres.shp"
)


@pytest.fixture(scope="module")
def countries():
    return gpd.read_file(SHAPEFILE)


@pytest.mark.parametrize("topology", ["per-feature", "shared"])
@pytest.mark.parametrize("tolerance_m", [100, 1000])
def test_natural_earth_countries_from_a_shapefile_come_back_whole(
    countries, tolerance_m, topology, tmp_path
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
    # The same geometries as the CLI on the file written as GeoJSON.
    path = tmp_path / "countries.geojson"
    gdf.to_file(path, driver="GeoJSON")
    cli = run_cli("fit", "--tolerance-m", tolerance_m, "--topology", topology, "-q", path)[
        "features"
    ]
    assert len(cli) == len(out)
    for i, f in enumerate(cli):
        got = out.geometry.iloc[i]
        want = shapely.geometry.shape(f["geometry"])
        assert shapely.equals_exact(got, want, tolerance=1e-9), (i, f["properties"]["name"])
