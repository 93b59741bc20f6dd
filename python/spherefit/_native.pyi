"""Type stubs of the extension module ``spherefit._native`` (Rust, PyO3).

The geometry functions return three lists, one item per input: the output geometry as WKB
(``None``: the input passes through unchanged), the operation's properties object as JSON text
(``properties.fit`` / ``interpolation`` / ``evaluation`` of the CLI), and that object's scalar
fields as a dict (``fit_wkb`` adds, for ``topology="shared"``, the coverage's ``topology``
member as JSON text). The GeoJSON options are keywords (``**options``: the query parameters of
the service, ``None`` for not given), checked by the library's ``into_job``. They release the GIL and run the features in parallel. Errors are
:class:`spherefit.SpherefitError`; a Ctrl-C during a call cancels the work and raises
``KeyboardInterrupt``.
"""

from typing import Dict, List, Optional, Sequence, Tuple, Union

_Scalar = Union[int, float, bool, str]
_Columns = Tuple[List[Optional[bytes]], List[Optional[str]], List[Optional[Dict[str, _Scalar]]]]
_FitColumns = Tuple[
    List[Optional[bytes]], List[Optional[str]], List[Optional[Dict[str, _Scalar]]], Optional[str]
]

__version__: str
__all__ = [
    "__version__",
    "fit_wkb",
    "interpolate_wkb",
    "evaluate_json",
    "sphere_fit",
    "sphere_interpolate",
    "sphere_evaluate",
]

def fit_wkb(
    wkbs: Sequence[Optional[bytes]],
    *,
    properties: Optional[Sequence[Optional[str]]] = None,
    max_samples: int = 100_000,
    max_control_points: int = 10_000,
    max_iterations: int = 1_000,
    **options: Union[int, float, bool, str, None],
) -> _FitColumns: ...
def interpolate_wkb(
    wkbs: Sequence[Optional[bytes]],
    *,
    max_samples: int = 100_000,
    **options: Union[int, float, bool, str, None],
) -> _Columns: ...
def evaluate_json(
    docs: Sequence[Optional[str]],
    key: str = "fit",
    *,
    max_samples: int = 100_000,
    max_control_points: int = 10_000,
    **options: Union[int, float, bool, str, None],
) -> _Columns: ...
def sphere_fit(
    data: bytes,
    m: int,
    d: int,
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
) -> str: ...
def sphere_interpolate(
    data: bytes,
    m: int,
    d: int,
    *,
    beta1: Sequence[float] = ...,
    beta2: Sequence[float] = ...,
    solver: str = "newton",
    max_iterations: Optional[int] = None,
) -> str: ...
def sphere_evaluate(
    doc: str, samples: int = 101, at: Optional[Sequence[float]] = None
) -> Tuple[List[float], bytes, int]: ...
