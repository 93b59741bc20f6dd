"""The exception raised for bad input (kept in its own module so the extension can raise it)."""

from __future__ import annotations

from typing import Optional


class SpherefitError(ValueError):
    """Input that spherefit cannot process, or an option out of range.

    A ``ValueError``. Attributes:

    * ``index``: the position of the offending feature in the input (0-based, ``None`` for an
      option or for the S^n functions);
    * ``pointer``: an RFC 6901 JSON pointer into the GeoJSON form of that geometry
      (``/coordinates/17/1`` is the latitude of position 17; ``/coordinates/2/5`` is position 5
      of part or ring 2), or into the points (``/points/3/0``) or spline document; ``""`` for
      the geometry as a whole, ``None`` for an option;
    * ``problem``: a stable name for the kind of problem (``invalid-coordinate``,
      ``too-few-points``, ``invalid-option``, ... as in the HTTP service's problem types).
    """

    def __init__(
        self,
        message: str,
        index: Optional[int] = None,
        pointer: Optional[str] = None,
        problem: Optional[str] = None,
    ) -> None:
        super().__init__(message)
        self.index = index
        self.pointer = pointer
        self.problem = problem
