"""Dask: the same functions per partition of a dask-geopandas GeoDataFrame, with the output
meta set, so ``spherefit.dask.fit(ddf, tolerance_m=50).compute()`` equals
``spherefit.fit(ddf.compute(), tolerance_m=50)`` row by row."""

from __future__ import annotations

from typing import Any

from . import _earth


def _map(function: Any, ddf: Any, options: dict):
    # The meta is the function run on the empty meta frame: same columns, dtypes and CRS.
    meta = function(ddf._meta, **options)
    return ddf.map_partitions(function, meta=meta, **options)


def fit(ddf: Any, **options: Any):
    """:func:`spherefit.fit` on every partition of ``ddf`` (a dask_geopandas.GeoDataFrame)."""
    return _map(_earth.fit, ddf, options)


def interpolate(ddf: Any, **options: Any):
    """:func:`spherefit.interpolate` on every partition of ``ddf``."""
    return _map(_earth.interpolate, ddf, options)


def evaluate(ddf: Any, **options: Any):
    """:func:`spherefit.evaluate` on every partition of ``ddf`` (with a ``fit`` column)."""
    return _map(_earth.evaluate, ddf, options)


__all__ = ["fit", "interpolate", "evaluate"]
