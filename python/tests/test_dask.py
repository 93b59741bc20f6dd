"""Dask: dask-geopandas partitions on a LocalCluster of 2 worker processes give the same rows
as one process."""

import dask_geopandas
import pandas as pd
import pytest
import shapely
from distributed import Client, LocalCluster

import spherefit
import spherefit.dask
from conftest import FIXTURES, frame


@pytest.fixture(scope="module")
def client():
    # Ports in this project's range for the tests (127.0.0.1 only, no dashboard).
    cluster = LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        scheduler_port=18601,
        dashboard_address=None,
        worker_port="18610:18619",
        port="18620:18629",  # the nannies
    )
    with Client(cluster) as c:
        yield c
    cluster.close()


def many_tracks():
    """The 8 GPS tracks and the 3 border resolutions, 4 times over: 44 features."""
    base = pd.concat(
        [frame(FIXTURES / "gps_tracks_slovenia_gpxpy.geojson")[["name", "geometry"]],
         frame(FIXTURES / "us_mexico_border_natural_earth.geojson")[["name", "geometry"]]],
        ignore_index=True,
    )
    gdf = pd.concat([base] * 4, ignore_index=True)
    gdf["row"] = range(len(gdf))
    return gdf.set_crs("EPSG:4326", allow_override=True)


def assert_same_rows(a, b, added):
    assert list(a.columns) == list(b.columns)
    assert list(a.index) == list(b.index)
    assert a.crs == b.crs
    for col in a.columns:
        if col == "geometry":
            assert shapely.to_wkb(a.geometry.values).tolist() == shapely.to_wkb(b.geometry.values).tolist()
        else:
            assert a[col].tolist() == b[col].tolist(), col
    # Dask turns the input's text columns into its own string dtype; the added columns keep theirs.
    for col in added:
        assert a[col].dtype == b[col].dtype, col


def test_dask_fit_equals_single_process(client):
    gdf = many_tracks()
    ddf = dask_geopandas.from_geopandas(gdf, npartitions=8)
    assert ddf.npartitions == 8
    single = spherefit.fit(gdf, tolerance_m=10)
    # The helper (meta set for you) and plain map_partitions give the same as one process.
    added = spherefit.output_columns("fit", tolerance_m=10)
    helped = spherefit.dask.fit(ddf, tolerance_m=10).compute()
    assert_same_rows(helped, single, added)
    plain = ddf.map_partitions(spherefit.fit, tolerance_m=10).compute()
    assert_same_rows(plain, single, added)
    # The cluster had its two worker processes.
    assert len(client.scheduler_info()["workers"]) == 2


def test_dask_interpolate_and_evaluate_equal_single_process(client):
    gdf = many_tracks().iloc[:16]
    ddf = dask_geopandas.from_geopandas(gdf, npartitions=4)
    assert_same_rows(
        spherefit.dask.interpolate(ddf, samples=50).compute(),
        spherefit.interpolate(gdf, samples=50),
        spherefit.output_columns("interpolate"),
    )
    fitted = spherefit.fit(gdf)
    dfit = dask_geopandas.from_geopandas(fitted, npartitions=4)
    assert_same_rows(
        spherefit.dask.evaluate(dfit, samples=20).compute(),
        spherefit.evaluate(fitted, samples=20),
        spherefit.output_columns("evaluate"),
    )


def test_dask_bad_input_raises_the_feature_error(client):
    gdf = many_tracks().iloc[:8].copy()
    gdf.loc[6, "geometry"] = shapely.LineString([(0, 0), (0, 91)])
    ddf = dask_geopandas.from_geopandas(gdf, npartitions=4)
    with pytest.raises(spherefit.SpherefitError, match="feature 0 \\(index 6\\) at /coordinates/1/1: latitude 91"):
        spherefit.dask.fit(ddf).compute()
