"""Input checks of the ``clamp`` modules: the project's checks (:mod:`scenes.validation`)
raising :mod:`clamp.errors` classes (ShapeError, NonFiniteError, InvalidParameterError)."""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from clamp.errors import InvalidParameterError, NonFiniteError, ShapeError
from scenes import validation as _checks

_ERRORS = _checks.ErrorKinds(ShapeError, NonFiniteError, InvalidParameterError)


def as_array(x: object, name: str, shape: Sequence[int | str | None]) -> np.ndarray:
    """``x`` as a finite float64 array of ``shape`` (ints, None = any, strings = equal sizes)."""
    return _checks.as_shaped(x, name, shape, _ERRORS)


def as_scalar(x: object, name: str, minimum: float | None = None,
              strictly_positive: bool = False) -> float:
    """``x`` as a finite float, checking ``x >= minimum`` or ``x > 0``."""
    return _checks.as_scalar(x, name, minimum=minimum, strictly_positive=strictly_positive,
                             error=_ERRORS)


def as_count(x: object, name: str, minimum: int = 1) -> int:
    """``x`` as an int >= ``minimum`` (bools and non-integral numbers rejected)."""
    return _checks.as_count(x, name, minimum, _ERRORS)


def as_time(x: object, name: str, length: int | None = None) -> np.ndarray:
    """A strictly increasing finite time vector (T,) in seconds."""
    return _checks.as_time(x, name, length, _ERRORS)
