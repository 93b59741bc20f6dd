"""Spark: the fit per Arrow batch through ``DataFrame.mapInArrow`` on a WKB column (no Sedona
needed). ``spherefit.spark.fit(df, tolerance_m=50)`` returns a DataFrame with the input's
columns, the WKB geometry column replaced by the fitted curve (WKB), and the metric columns and
JSON column of :func:`spherefit.fit`, with the same values."""

from __future__ import annotations

from typing import Any, Iterator

from . import _earth, _native

_ARROW = {"float64": "float64", "Int64": "int64", "boolean": "bool_", "object": "string"}
_SPARK = {"float64": "double", "Int64": "bigint", "boolean": "boolean", "object": "string"}
_NATIVE = {"fit": "fit_wkb", "interpolate": "interpolate_wkb"}


def batches(
    batches: Iterator[Any], operation: str = "fit", geometry: str = "geometry", **options: Any
) -> Iterator[Any]:
    """The function for ``mapInArrow``: each ``pyarrow.RecordBatch`` with its WKB column
    ``geometry`` fitted (``operation`` ``fit`` or ``interpolate``, with ``options``)."""
    import pyarrow as pa

    native = getattr(_native, _NATIVE[operation])
    cols = _earth.output_columns(operation, options.get("tolerance_m"))
    for batch in batches:
        wkbs = batch.column(geometry).to_pylist()
        # fit_wkb adds a fourth item (the coverage's arcs with topology="shared").
        out_wkbs, infos, scalars = native(wkbs, **options)[:3]
        names, arrays = [], []
        for name in batch.schema.names:
            if name in cols:
                continue
            names.append(name)
            if name == geometry:
                merged = [o if n is None else n for n, o in zip(out_wkbs, wkbs)]
                arrays.append(pa.array(merged, type=pa.binary()))
            else:
                arrays.append(batch.column(name))
        for name, dtype in cols.items():
            names.append(name)
            if dtype == "object":
                values = infos
            else:
                values = [None if s is None else s.get(name) for s in scalars]
            arrays.append(pa.array(values, type=getattr(pa, _ARROW[dtype])()))
        yield pa.RecordBatch.from_arrays(arrays, names=names)


def schema(input_schema: Any, operation: str = "fit", tolerance_m: Any = None) -> str:
    """The output schema (DDL) of :func:`batches` for a DataFrame of ``input_schema``."""
    cols = _earth.output_columns(operation, tolerance_m)
    fields = [f"`{f.name}` {f.dataType.simpleString()}" for f in input_schema.fields if f.name not in cols]
    fields += [f"`{name}` {_SPARK[dtype]}" for name, dtype in cols.items()]
    return ", ".join(fields)


def fit(df: Any, geometry: str = "geometry", **options: Any):
    """:func:`spherefit.fit` on a Spark DataFrame whose ``geometry`` column is WKB (binary)."""
    return _map(df, "fit", geometry, options)


def interpolate(df: Any, geometry: str = "geometry", **options: Any):
    """:func:`spherefit.interpolate` on a Spark DataFrame with a WKB column."""
    return _map(df, "interpolate", geometry, options)


def _map(df: Any, operation: str, geometry: str, options: dict):
    if geometry not in df.columns:
        from ._errors import SpherefitError

        raise SpherefitError(f"geometry: no column {geometry!r}", problem="invalid-option")
    out_schema = schema(df.schema, operation, options.get("tolerance_m"))

    def run(it: Iterator[Any]) -> Iterator[Any]:
        return batches(it, operation, geometry, **options)

    return df.mapInArrow(run, out_schema)


__all__ = ["batches", "schema", "fit", "interpolate"]
