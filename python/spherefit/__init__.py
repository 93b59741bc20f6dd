"""spherefit: smooth spherical spline curves fitted to lines on the Earth and to points on S^n.

* :func:`fit`, :func:`interpolate`, :func:`evaluate`: shapely arrays, GeoSeries and
  GeoDataFrames of lon/lat lines and rings (the numbers of ``spherefit fit | interpolate |
  evaluate``); :func:`fit_file` for GeoParquet datasets.
* :mod:`spherefit.sphere`: numpy arrays of unit vectors on any S^n.
* :mod:`spherefit.dask` and :mod:`spherefit.spark`: the same per partition on a cluster.

Bad input raises :class:`SpherefitError` (a ``ValueError``) naming the feature and coordinate.
"""

from . import sphere
from ._earth import (
    EVALUATE_COLUMNS,
    FIT_COLUMNS,
    INTERPOLATE_COLUMNS,
    TOLERANCE_COLUMNS,
    evaluate,
    fit,
    fit_file,
    interpolate,
    output_columns,
)
from ._errors import SpherefitError
from ._native import __version__

__all__ = [
    "fit",
    "interpolate",
    "evaluate",
    "fit_file",
    "output_columns",
    "sphere",
    "SpherefitError",
    "FIT_COLUMNS",
    "TOLERANCE_COLUMNS",
    "INTERPOLATE_COLUMNS",
    "EVALUATE_COLUMNS",
    "__version__",
]
