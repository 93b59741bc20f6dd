"""Lines and rings on the Earth: shapely arrays, GeoSeries and GeoDataFrames in and out.

Geometry crosses to Rust as WKB (``shapely.to_wkb``), one call per array; the extension
releases the GIL and fits the features in parallel; the output comes back as WKB
(``shapely.from_wkb``). Each geometry goes through the same library functions as a feature of
``spherefit fit`` (the CLI) or ``POST /v1/fit`` (the service), so the numbers are theirs.
"""

from __future__ import annotations

import json
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np
import shapely

from . import _native
from ._errors import SpherefitError

#: Metric columns of :func:`fit` and their pandas dtypes (the fields of ``properties.fit``).
FIT_COLUMNS: Dict[str, str] = {
    "max_error_m": "float64",
    "mean_error_m": "float64",
    "rms_error_m": "float64",
    "input_points": "Int64",
    "control_points": "Int64",
    "iterations": "Int64",
    "converged": "boolean",
    "output_points": "Int64",
    "sampling_deviation_m": "float64",
}
#: Extra metric columns of :func:`fit` with ``tolerance_m``.
TOLERANCE_COLUMNS: Dict[str, str] = {
    "tolerance_met": "boolean",
    "stored_numbers": "Int64",
    "compression_ratio": "float64",
}
#: Metric columns of :func:`interpolate` (the fields of ``properties.interpolation``).
INTERPOLATE_COLUMNS: Dict[str, str] = {
    "max_error_m": "float64",
    "input_points": "Int64",
    "output_points": "Int64",
    "sampling_deviation_m": "float64",
}
#: Metric columns of :func:`evaluate` (the fields of ``properties.evaluation``).
EVALUATE_COLUMNS: Dict[str, str] = {
    "output_points": "Int64",
    "sampling_deviation_m": "float64",
}


def _geometry_input(geoms: Any) -> Tuple[np.ndarray, Any, Any, Any]:
    """(object array of shapely geometries or None, index, crs, frame or None)."""
    import geopandas as gpd

    if isinstance(geoms, gpd.GeoDataFrame):
        return np.asarray(geoms.geometry.values, dtype=object), geoms.index, geoms.crs, geoms
    if isinstance(geoms, gpd.GeoSeries):
        return np.asarray(geoms.values, dtype=object), geoms.index, geoms.crs, None
    if isinstance(geoms, shapely.Geometry):
        raise SpherefitError(
            "geoms: expected an array, GeoSeries or GeoDataFrame of geometries, got one "
            "geometry: pass [geometry]",
            problem="invalid-option",
        )
    arr = np.asarray(geoms, dtype=object)
    if arr.ndim != 1:
        raise SpherefitError(
            f"geoms: expected a 1-D array of geometries, got shape {arr.shape}",
            problem="invalid-option",
        )
    for i, g in enumerate(arr):
        if g is not None and not isinstance(g, shapely.Geometry):
            raise SpherefitError(
                f"feature {i}: expected a shapely geometry or None, got {type(g).__name__}",
                index=i,
                pointer="",
                problem="invalid-geometry",
            )
    return arr, None, None, None


def _check_crs(crs: Any) -> None:
    if crs is not None and not crs.is_geographic:
        raise SpherefitError(
            f"crs: {crs.to_string()} is not a geographic CRS: spherefit takes longitude and "
            "latitude in degrees; reproject first (.to_crs(4326))",
            problem="invalid-option",
        )


def _to_wkb(arr: np.ndarray) -> List[Optional[bytes]]:
    return list(shapely.to_wkb(arr)) if len(arr) else []


def _assemble(
    arr: np.ndarray,
    index: Any,
    crs: Any,
    frame: Any,
    result: Tuple[List[Optional[bytes]], List[Optional[str]], List[Optional[dict]]],
    columns: Dict[str, str],
    json_column: str,
):
    """The output GeoDataFrame: input columns kept, geometry replaced where a curve was made
    (and missing where the curve is kept without it, ``carry="spline"``)."""
    import geopandas as gpd
    import pandas as pd

    wkbs, infos, scalars = result
    out_geoms = arr.copy()
    done = np.array([w is not None for w in wkbs], dtype=bool)
    if done.any():
        out_geoms[done] = shapely.from_wkb(np.array([w for w in wkbs if w is not None], dtype=object))
    spline_only = np.array([w is None and i is not None for w, i in zip(wkbs, infos)], dtype=bool)
    out_geoms[spline_only] = None
    if frame is not None:
        out = frame.copy()
        name = frame.geometry.name
        out[name] = gpd.GeoSeries(out_geoms, index=frame.index, crs=crs)
    else:
        idx = index if index is not None else pd.RangeIndex(len(arr))
        out = gpd.GeoDataFrame(geometry=gpd.GeoSeries(out_geoms, index=idx, crs=crs), index=idx)
    for name, dtype in columns.items():
        values = [None if s is None else s.get(name) for s in scalars]
        out[name] = pd.Series(pd.array(values, dtype=dtype), index=out.index)
    out[json_column] = pd.Series(infos, index=out.index, dtype=object)
    return out


def _call(native: Any, index: Any, *args: Any, **kwargs: Any):
    """Runs a native function; a feature error also names the row's index label (the position
    alone is local to a Dask or Spark partition)."""
    try:
        return native(*args, **kwargs)
    except SpherefitError as e:
        import pandas as pd

        plain = isinstance(index, pd.RangeIndex) and index.start == 0 and index.step == 1
        if e.index is None or index is None or plain:
            raise
        label = index[e.index]
        message = str(e).replace(f"feature {e.index}", f"feature {e.index} (index {label!r})", 1)
        raise SpherefitError(message, e.index, e.pointer, e.problem) from None


#: The properties a fit in time reads its times from when ``time_property`` is not given, in
#: this order (those of ``spherefit fit``).
TIME_PROPERTIES: Sequence[str] = ("coordTimes", "times", "timestamps")


def _json_value(v: Any) -> Any:
    """A cell of a time column as JSON: lists, arrays and timestamps (RFC 3339 text)."""
    if isinstance(v, np.ndarray):
        v = v.tolist()
    if isinstance(v, (list, tuple)):
        return [_json_value(x) for x in v]
    if hasattr(v, "isoformat"):
        return v.isoformat().replace("+00:00", "Z")
    if isinstance(v, np.generic):
        return v.item()
    return v


def _time_properties(frame: Any, n: int, options: Dict[str, Any]) -> Optional[List[Optional[str]]]:
    """For a fit in time, each row's time column as a properties object (JSON text), as the
    CLI reads ``time_property`` (or the first of :data:`TIME_PROPERTIES`) from a feature."""
    in_time = (
        options.get("parameterization") == "time"
        or options.get("time_property") is not None
        or options.get("spacing_s") is not None
    )
    if not in_time or frame is None:
        return None
    name = options.get("time_property")
    names = [name] if name is not None else [c for c in TIME_PROPERTIES if c in frame.columns]
    names = [c for c in names if c in frame.columns]
    if not names:
        return None
    rows: List[Optional[str]] = []
    for i in range(n):
        props = {}
        for c in names:
            v = frame[c].iloc[i]
            if v is None or (isinstance(v, float) and np.isnan(v)):
                continue
            props[c] = _json_value(v)
        rows.append(json.dumps(props))
    return rows


def _times_text(at: Any) -> Optional[str]:
    """``at`` as the comma-separated text the CLI's ``--at`` takes: numbers (unix seconds),
    RFC 3339 strings, datetimes or pandas Timestamps, or that text already."""
    if at is None or isinstance(at, str):
        return at
    if not isinstance(at, (list, tuple, np.ndarray)) and not hasattr(at, "__iter__"):
        at = [at]
    return ",".join(str(_json_value(t)) for t in at)


def fit(
    geoms: Any,
    *,
    tolerance_m: Optional[float] = None,
    control_points: Optional[int] = None,
    degree: int = 3,
    knots: str = "adaptive",
    solver: str = "gls-pia-accelerated",
    parameter_correction: bool = False,
    samples: Optional[int] = None,
    spacing_m: Optional[float] = None,
    spacing_s: Optional[float] = None,
    iterations: int = 30,
    parameterization: Optional[str] = None,
    time_property: Optional[str] = None,
    topology: str = "per-feature",
    drop_small_rings: bool = False,
    carry: str = "both",
    precision: Optional[int] = None,
    max_samples: int = 100_000,
    max_control_points: int = 10_000,
    max_iterations: int = 1_000,
):
    """Fit spherical B-splines to lon/lat lines and rings, as ``spherefit fit`` does.

    ``geoms`` is a shapely array (or list), a GeoSeries or a GeoDataFrame of geometries in
    longitude/latitude degrees (``[lon, lat]`` or ``[lon, lat, altitude]``). Every LineString,
    each part of a MultiLineString and every Polygon and MultiPolygon ring is fitted on the
    sphere (antimeridian and poles included); other geometries and missing values pass through
    unchanged with missing metrics.

    Returns a GeoDataFrame with the input's index and CRS (for a GeoDataFrame, all its columns
    too): the geometry is the dense fitted curve (cut at +-180 degrees), the columns of
    :data:`FIT_COLUMNS` (plus :data:`TOLERANCE_COLUMNS` with ``tolerance_m``) hold the metrics
    (parametric geodesic errors in metres of the spline as returned), and ``fit`` holds
    ``properties.fit`` of the CLI as JSON text, the compact spline included, which
    :func:`evaluate` turns back into the curve. Columns of those names are overwritten.

    The options are those of ``spherefit fit`` and ``POST /v1/fit`` (the same names, values and
    defaults; the library checks them, so an error names the option as the service does):

    * ``tolerance_m``: fit each curve to this tolerance in metres with as few stored numbers as
      the fitter finds (excludes ``control_points``; ``degree`` caps the degrees tried, at most
      3). Default: none, a fit with ``control_points`` (default a quarter of the distinct
      positions, or half when a quarter leaves a position too far).
    * ``degree`` (1 to 5, default 3), ``knots`` (``adaptive`` default, ``geodesic``,
      ``euclidean``, ``uniform``), ``solver`` (``gls-pia-accelerated`` default, ``gls-pia``,
      ``gauss-newton``), ``parameter_correction`` (foot-point parameters between solver steps,
      default False),
      ``iterations`` (default 30).
    * ``parameterization``: ``chord`` (the default), ``centripetal``, ``uniform`` or ``time``
      (position as a function of time: with ``tolerance_m`` the bound is the synchronized
      distance). ``time_property`` names the column holding each row's times (a list of RFC
      3339 strings, datetimes or unix seconds, one per position; default the first of
      :data:`TIME_PROPERTIES` present) and, like ``spacing_s``, implies ``time``.
    * ``topology``: ``per-feature`` (default) or ``shared``: the Polygon and MultiPolygon rows
      are one coverage, each border shared by neighbours fitted once (needs ``tolerance_m``);
      the output frame's ``attrs["topology"]`` then holds the dataset report and every arc's
      spline (the ``topology`` member of the CLI's output).
    * ``drop_small_rings``: a ring that collapses under the fit is dropped and listed in
      ``dropped_rings`` of the ``fit`` JSON instead of kept as a small valid ring (default
      False); a row left with no polygon gets an empty MultiPolygon.
    * Output density: ``samples`` points per curve, or ``spacing_m`` metres apart (both: at most
      that far apart and at least that many), or for a fit in time ``spacing_s`` seconds apart;
      default automatic. ``precision`` decimals of output degrees (default 7; with
      ``tolerance_m`` the fewest whose rounding stays within a tenth of the tolerance, 4 at
      100 m and 3 at 1 km, counted in the certified bound).
    * ``carry``: what each row keeps: ``both`` (default: the geometry, and the spline in
      ``fit``), ``geometry`` (no spline in ``fit``) or ``spline`` (geometry missing;
      :func:`evaluate` draws it).
    * Limits: ``max_samples``, ``max_control_points``, ``max_iterations``.

    Raises :class:`SpherefitError` (a ``ValueError``) naming the feature index and the
    coordinate (``feature 3 at /coordinates/17/1: ...``) or the option.
    """
    arr, index, crs, frame = _geometry_input(geoms)
    _check_crs(crs)
    options: Dict[str, Any] = dict(
        tolerance_m=tolerance_m,
        control_points=control_points,
        degree=degree,
        knots=knots,
        iterations=iterations,
        parameterization=parameterization,
        time_property=time_property,
        solver=solver,
        parameter_correction=parameter_correction,
        samples=samples,
        spacing_m=spacing_m,
        spacing_s=spacing_s,
        precision=precision,
        topology=topology,
        drop_small_rings=drop_small_rings,
        carry=carry,
    )
    wkbs, infos, scalars, topology_json = _call(
        _native.fit_wkb,
        index,
        _to_wkb(arr),
        properties=_time_properties(frame, len(arr), options),
        max_samples=max_samples,
        max_control_points=max_control_points,
        max_iterations=max_iterations,
        **options,
    )
    columns = dict(FIT_COLUMNS)
    if tolerance_m is not None:
        columns.update(TOLERANCE_COLUMNS)
    out = _assemble(arr, index, crs, frame, (wkbs, infos, scalars), columns, "fit")
    if topology_json is not None:
        out.attrs["topology"] = json.loads(topology_json)
    return out


def interpolate(
    geoms: Any,
    *,
    beta1: float = 1.0,
    beta2: float = 0.0,
    samples: Optional[int] = None,
    spacing_m: Optional[float] = None,
    precision: int = 7,
    max_samples: int = 100_000,
):
    """Smooth spherical Beta-splines through every vertex, as ``spherefit interpolate``.

    Input and output as for :func:`fit`; the metric columns are :data:`INTERPOLATE_COLUMNS`
    and the JSON column is ``interpolation`` (the curve document included). ``beta1`` is the
    bias (1e-6 to 1e6, 1 is none) and ``beta2`` the tension (>= 0) at every vertex.
    """
    arr, index, crs, frame = _geometry_input(geoms)
    _check_crs(crs)
    result = _call(
        _native.interpolate_wkb,
        index,
        _to_wkb(arr),
        beta1=beta1,
        beta2=beta2,
        samples=samples,
        spacing_m=spacing_m,
        precision=precision,
        max_samples=max_samples,
    )
    return _assemble(arr, index, crs, frame, result, INTERPOLATE_COLUMNS, "interpolation")


def evaluate(
    curves: Any,
    *,
    samples: Optional[int] = None,
    spacing_m: Optional[float] = None,
    spacing_s: Optional[float] = None,
    at: Any = None,
    key: Optional[str] = None,
    precision: int = 7,
    max_samples: int = 100_000,
    max_control_points: int = 10_000,
):
    """Dense geometry from stored curves, as ``spherefit evaluate``.

    ``curves`` is the output of :func:`fit` or :func:`interpolate` (a GeoDataFrame with a
    ``fit`` or ``interpolation`` column of JSON text; ``key`` picks one when both are there),
    or a sequence of such JSON texts or dicts (``None`` for none; then ``key`` says which kind,
    default ``fit``). Returns a GeoDataFrame whose geometry is the curve sampled as ``samples``
    / ``spacing_m`` say (or, for a fit in time, every ``spacing_s`` seconds), with the columns
    of :data:`EVALUATE_COLUMNS` and ``evaluation`` (JSON); rows without a curve keep their
    geometry. ``at`` (fits in time only): the positions at these times instead (a MultiPoint
    per row), with ``speed_mps`` and ``heading_deg`` in ``evaluation``; unix seconds, RFC 3339
    strings or datetimes (a list, or the CLI's comma-separated text).
    """
    import geopandas as gpd

    frame = None
    if isinstance(curves, gpd.GeoDataFrame):
        frame = curves
        if key is None:
            key = "fit" if "fit" in frame.columns else "interpolation"
        if key not in frame.columns:
            raise SpherefitError(
                f"curves: no {key!r} column (as written by spherefit.fit or interpolate)",
                problem="invalid-option",
            )
        docs = list(frame[key])
        arr = np.asarray(frame.geometry.values, dtype=object)
        index, crs = frame.index, frame.crs
    else:
        docs = list(curves)
        arr = np.full(len(docs), None, dtype=object)
        index, crs = None, "EPSG:4326"
        key = key or "fit"
    texts: List[Optional[str]] = []
    for i, d in enumerate(docs):
        if d is None or (isinstance(d, float) and np.isnan(d)):
            texts.append(None)
        elif isinstance(d, str):
            texts.append(d)
        elif isinstance(d, dict):
            texts.append(json.dumps(d))
        else:
            raise SpherefitError(
                f"feature {i}: expected the {key} JSON as text or a dict, got {type(d).__name__}",
                index=i,
                pointer="",
                problem="invalid-spline",
            )
    result = _call(
        _native.evaluate_json,
        index,
        texts,
        key,
        samples=samples,
        spacing_m=spacing_m,
        spacing_s=spacing_s,
        at=_times_text(at),
        precision=precision,
        max_samples=max_samples,
        max_control_points=max_control_points,
    )
    return _assemble(arr, index, crs, frame, result, EVALUATE_COLUMNS, "evaluation")


def fit_file(src: str, dst: str, **options: Any):
    """Fit every line of a dataset file and write the result, through geopandas.

    ``src`` and ``dst`` ending in ``.parquet`` (or ``.geoparquet``) are GeoParquet (read and
    written with pyarrow, CRS kept); any other name is read and written with
    ``geopandas.read_file`` / ``to_file`` (needs pyogrio). ``options`` are those of
    :func:`fit`. Returns the fitted GeoDataFrame.
    """
    import geopandas as gpd

    def parquet(p: str) -> bool:
        return str(p).endswith((".parquet", ".geoparquet"))

    gdf = gpd.read_parquet(src) if parquet(src) else gpd.read_file(src)
    out = fit(gdf, **options)
    if parquet(dst):
        out.to_parquet(dst)
    else:
        out.to_file(dst)
    return out


def output_columns(operation: str, tolerance_m: Optional[float] = None) -> Dict[str, str]:
    """The metric columns (name -> pandas dtype) that ``operation`` (``fit``, ``interpolate``
    or ``evaluate``) adds, followed by its JSON column (dtype ``object``)."""
    if operation == "fit":
        cols = dict(FIT_COLUMNS)
        if tolerance_m is not None:
            cols.update(TOLERANCE_COLUMNS)
        cols["fit"] = "object"
    elif operation == "interpolate":
        cols = dict(INTERPOLATE_COLUMNS)
        cols["interpolation"] = "object"
    elif operation == "evaluate":
        cols = dict(EVALUATE_COLUMNS)
        cols["evaluation"] = "object"
    else:
        raise SpherefitError(
            f"operation: {operation!r}: use fit, interpolate or evaluate", problem="invalid-option"
        )
    return cols


__all__: Sequence[str] = [
    "fit",
    "interpolate",
    "evaluate",
    "fit_file",
    "output_columns",
    "FIT_COLUMNS",
    "TOLERANCE_COLUMNS",
    "INTERPOLATE_COLUMNS",
    "EVALUATE_COLUMNS",
    "TIME_PROPERTIES",
]
