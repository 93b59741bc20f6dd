"""Whole datasets back whole: Natural Earth's 110m countries as GIS packages ship them, and
the world-atlas 10m countries.

pyogrio's `naturalearth_lowres` shapefile (the file geopandas shipped before 1.0) cuts Fiji and
Russia at ±180 and closes Antarctica along the South Pole. Converted by GDAL
(`fixtures/naturalearth_lowres_gdal.geojson`), `spherefit.fit` gives every row back, every ring
valid for shapely, and the same geometries as the CLI on the same data. Read straight from the
shapefile, Russia holds a longitude of 180.00000000000006 (floating-point noise past the line,
which GDAL's GeoJSON writer rounds away): refused with its row and position, as every
coordinate out of range is.
"""

import json
import os
import subprocess
from pathlib import Path

import geopandas as gpd
import numpy as np
import pyogrio
import pytest
import shapely

import spherefit
from conftest import FIXTURES, ROOT, run_cli

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


@pytest.fixture(scope="module")
def world_atlas_10m(tmp_path_factory):
    """npm world-atlas's Natural Earth 10m countries, decoded by topojson-client (as the Rust
    tests decode them: `scripts/coverage/topojson_read.mjs`, needs `npm ci --prefix
    scripts/coverage`, which .ci/run does)."""
    script = ROOT / "scripts" / "coverage" / "topojson_read.mjs"
    installed = (ROOT / "scripts" / "coverage" / "node_modules" / "world-atlas").exists()
    if not installed:
        if os.environ.get("SPHEREFIT_TEST_TOOLS") == "required":
            pytest.fail("world-atlas is not installed: npm ci --prefix scripts/coverage")
        pytest.skip("world-atlas (npm ci --prefix scripts/coverage) is not installed")
    out = tmp_path_factory.mktemp("world-atlas") / "countries-10m.geojson"
    subprocess.run(
        ["node", str(script), "world-atlas", "countries-10m", str(out)], check=True
    )
    return out


def _as_written(geometry, decimals=7):
    """The geometry with its coordinates rounded as the output writes them."""
    return shapely.transform(geometry, lambda c: np.round(c, decimals))


@pytest.mark.parametrize("topology", ["per-feature", "shared"])
@pytest.mark.parametrize("tolerance_m", [100, 1000])
def test_world_atlas_10m_countries_come_back_whole_and_valid(
    world_atlas_10m, tolerance_m, topology
):
    """Every row back, every ring of at least 4 positions, and every polygon valid for shapely
    wherever the input, written at the output's 7 decimals, is (54 of the 255 input features
    are invalid as topojson-client decodes them; spherefit does not repair them)."""
    gdf = gpd.read_file(world_atlas_10m)
    assert len(gdf) == 255
    out = spherefit.fit(gdf, tolerance_m=tolerance_m, topology=topology)
    assert len(out) == len(gdf)
    assert out["name"].tolist() == gdf["name"].tolist()
    assert not out.geometry.isna().any()
    rings = shapely.get_rings(shapely.get_parts(out.geometry.values))
    assert (shapely.get_num_coordinates(rings) >= 4).all()
    valid_in = shapely.is_valid(_as_written(gdf.geometry.values))
    assert valid_in.sum() >= 190, valid_in.sum()
    valid_out = shapely.is_valid(out.geometry.values)
    broken = {
        gdf["name"].iloc[i]: shapely.is_valid_reason(out.geometry.iloc[i])
        for i in np.flatnonzero(valid_in & ~valid_out)
    }
    assert not broken, broken
