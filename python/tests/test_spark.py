"""Spark: mapInArrow on a WKB column in a local[2] session gives the same rows as one process."""

import os
import sys

import pandas as pd
import pytest
import shapely

import spherefit
import spherefit.spark
from conftest import FIXTURES, frame


@pytest.fixture(scope="module")
def spark():
    from pyspark.sql import SparkSession

    os.environ["PYSPARK_PYTHON"] = sys.executable
    os.environ["PYSPARK_DRIVER_PYTHON"] = sys.executable
    session = (
        SparkSession.builder.master("local[2]")
        .appName("spherefit-test")
        .config("spark.ui.enabled", "false")
        .config("spark.driver.host", "127.0.0.1")
        .config("spark.driver.bindAddress", "127.0.0.1")
        .config("spark.driver.port", "18640")
        .config("spark.blockManager.port", "18641")
        .config("spark.sql.shuffle.partitions", "2")
        .config("spark.sql.execution.arrow.maxRecordsPerBatch", "5")
        .getOrCreate()
    )
    yield session
    session.stop()


def wkb_table():
    """The GPS tracks, the border and the batch fixture (antimeridian, Point, parts, ring, pole)
    as (row, name, WKB) rows: 17 features."""
    gdf = pd.concat(
        [frame(FIXTURES / p)[["name", "geometry"]] for p in (
            "gps_tracks_slovenia_gpxpy.geojson",
            "us_mexico_border_natural_earth.geojson",
            "batch_tracks.geojsons",
        )],
        ignore_index=True,
    ).set_crs("EPSG:4326", allow_override=True)
    gdf["row"] = range(len(gdf))
    pdf = pd.DataFrame({"row": gdf["row"], "name": gdf["name"].astype(object), "geometry": list(shapely.to_wkb(gdf.geometry.values))})
    return gdf, pdf


def nulls_as_none(column):
    return [None if pd.isna(x) else x for x in column]


def test_spark_fit_equals_single_process(spark):
    gdf, pdf = wkb_table()
    df = spark.createDataFrame(pdf).repartition(2)
    got = spherefit.spark.fit(df, tolerance_m=10).toPandas().sort_values("row").reset_index(drop=True)
    want = spherefit.fit(gdf, tolerance_m=10)
    assert got["row"].tolist() == list(range(len(gdf)))
    assert list(got.columns) == ["row", "name", "geometry", *spherefit.output_columns("fit", 10)]
    out_geoms = shapely.from_wkb(got["geometry"].tolist())
    assert shapely.to_wkb(out_geoms).tolist() == shapely.to_wkb(want.geometry.values).tolist()
    for col in spherefit.output_columns("fit", 10):
        assert nulls_as_none(got[col]) == nulls_as_none(want[col]), col
    assert got["geometry"].iloc[13] == pdf["geometry"].iloc[13]  # the Point passes through
    assert gdf.geometry.iloc[13].geom_type == "Point" and pd.isna(got["max_error_m"].iloc[13])


def test_spark_interpolate_equals_single_process(spark):
    gdf, pdf = wkb_table()
    got = spherefit.spark.interpolate(spark.createDataFrame(pdf), samples=30).toPandas().sort_values("row")
    want = spherefit.interpolate(gdf, samples=30)
    assert nulls_as_none(got["interpolation"]) == nulls_as_none(want["interpolation"])


def test_spark_bad_input(spark):
    _, pdf = wkb_table()
    pdf.loc[3, "geometry"] = shapely.to_wkb(shapely.LineString([(0, 0), (0, 91)]))
    df = spark.createDataFrame(pdf)
    with pytest.raises(Exception, match="latitude 91"):
        spherefit.spark.fit(df).collect()
    with pytest.raises(spherefit.SpherefitError, match="no column 'geom'"):
        spherefit.spark.fit(df, geometry="geom")


def test_spark_reads_geoparquet_and_fits_it(spark, tmp_path):
    """The Spark example of docs/python.md: GeoParquet read as plain Parquet has a WKB column."""
    gdf, _ = wkb_table()
    path = tmp_path / "tracks.parquet"
    gdf.to_parquet(path)
    df = spark.read.parquet(str(path))
    assert dict(df.dtypes)["geometry"] == "binary"
    got = spherefit.spark.fit(df, geometry="geometry", tolerance_m=25).toPandas().sort_values("row")
    want = spherefit.fit(gdf, tolerance_m=25)
    assert nulls_as_none(got["fit"]) == nulls_as_none(want["fit"])
    out = tmp_path / "fitted"
    spherefit.spark.fit(df, tolerance_m=25).write.parquet(str(out))
    back = spark.read.parquet(str(out)).toPandas().sort_values("row")
    assert nulls_as_none(back["fit"]) == nulls_as_none(want["fit"])
