"""Curves on any S^n (n >= 1): numpy arrays of unit vectors in, the documents of
``spherefit sphere fit | interpolate | evaluate`` out (as dicts, equal to the CLI's JSON)."""

from __future__ import annotations

import json
from typing import Any, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native
from ._errors import SpherefitError


def _points(points: Any) -> Tuple[bytes, int, int]:
    try:
        a = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise SpherefitError(
            f"points: expected an (m, d) array of numbers: {e}", pointer="/points",
            problem="invalid-points",
        ) from None
    if a.ndim != 2:
        raise SpherefitError(
            f"points: expected an (m, d) array of unit vectors, got shape {a.shape}",
            pointer="/points",
            problem="invalid-points",
        )
    m, d = a.shape
    return np.ascontiguousarray(a, dtype="<f8").tobytes(), m, d


def fit(
    points: Any,
    parameters: Optional[Sequence[float]] = None,
    *,
    control_points: Optional[int] = None,
    degree: int = 3,
    knots: str = "geodesic",
    iterations: Optional[int] = None,
    parameterization: str = "chord",
    step: str = "deng-lin",
    solver: str = "gls-pia",
    target_max_error_rad: Optional[float] = None,
    tolerance_rad: Optional[float] = None,
    method: str = "gls-pia",
) -> dict:
    """Fit a spherical B-spline (GLS-PIA) to ordered unit vectors, as ``spherefit sphere fit``.

    ``points`` is an (m, d) array, d >= 2, each row a unit vector; ``parameters`` (optional,
    e.g. timestamps) one non-decreasing value per point. Returns the CLI's document:
    ``{"spline": {"degree", "knots", "control_points"}, "parameters", "metrics": {max, mean,
    rms error in radians, iterations, converged}, "history"}``; with ``tolerance_rad``, a fit to
    that tolerance whose document has ``"tolerance"`` instead of ``"history"`` (not with
    ``control_points`` or ``target_max_error_rad``: the tolerance fit chooses its own).

    ``iterations`` defaults to the paper's 30. ``method`` is ``"gls-pia"`` (the paper's
    B-spline) or a method the paper compares itself with: ``"jupp-kent"``, ``"samir"``,
    ``"cbc"`` or ``"bcc"`` (``docs/paper.md``); these return ``{"method", "parameters",
    "fitted_points", "metrics", "iterations", "converged", "free_points", "curve": {"type":
    "polyline", "parameters", "points"}}``, take ``control_points`` as their budget of free
    points and ``iterations`` as a cap (Jupp-Kent rounds, Samir steps), and refuse the
    B-spline's own options (``degree``, ``knots``, ``step``, ``solver``, targets).

    Raises :class:`SpherefitError` naming the point (``/points/3/1``) or the option.
    """
    data, m, d = _points(points)
    params = None if parameters is None else [float(t) for t in parameters]
    text = _native.sphere_fit(
        data, m, d, params,
        control_points=control_points, degree=degree, knots=knots, iterations=iterations,
        parameterization=parameterization, step=step, solver=solver,
        target_max_error_rad=target_max_error_rad, tolerance_rad=tolerance_rad,
        method=method,
    )
    return json.loads(text)


def _per_point(v: Union[float, Sequence[float]]) -> list:
    if isinstance(v, (int, float, np.number)):
        return [float(v)]
    return [float(x) for x in v]


def interpolate(
    points: Any,
    *,
    beta1: Union[float, Sequence[float]] = 1.0,
    beta2: Union[float, Sequence[float]] = 0.0,
    solver: str = "newton",
    max_iterations: Optional[int] = None,
) -> dict:
    """A G1 spherical Beta-spline through every point, as ``spherefit sphere interpolate``.

    ``beta1`` (bias > 0) and ``beta2`` (tension >= 0): one value for every point or one per
    point. Returns ``{"curve": {"type": "beta", "beta1", "beta2", "segments"}, "residual_rad",
    "iterations"}``.
    """
    data, m, d = _points(points)
    text = _native.sphere_interpolate(
        data, m, d, beta1=_per_point(beta1), beta2=_per_point(beta2), solver=solver,
        max_iterations=max_iterations,
    )
    return json.loads(text)


def evaluate(
    curve: Union[dict, str], samples: int = 101, at: Optional[Sequence[float]] = None
) -> Tuple[np.ndarray, np.ndarray]:
    """Points of a curve, as ``spherefit sphere evaluate``.

    ``curve`` is a spline or Beta-spline document or the output of :func:`fit` or
    :func:`interpolate` (a dict or its JSON text). Evaluated at ``at`` (clamped to the domain)
    or at ``samples`` evenly spaced parameters, ends included. Returns ``(parameters, points)``:
    a (k,) and a (k, d) float64 array.
    """
    text = curve if isinstance(curve, str) else json.dumps(curve)
    at_list = None if at is None else [float(t) for t in at]
    ts, data, dim = _native.sphere_evaluate(text, samples, at_list)
    pts = np.frombuffer(data, dtype="<f8").reshape(len(ts), dim)
    return np.asarray(ts, dtype=np.float64), pts


__all__ = ["fit", "interpolate", "evaluate"]
