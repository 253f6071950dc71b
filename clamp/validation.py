"""Input checks of the ``clamp`` modules: the project's checks (:mod:`scenes.validation`)
raising :mod:`clamp.errors` classes (ShapeError, NonFiniteError, InvalidParameterError)."""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from clamp.errors import InvalidParameterError, NonFiniteError, ShapeError
from scenes import validation as _checks

_ERRORS = _checks.ErrorKinds(ShapeError, NonFiniteError, InvalidParameterError)


def as_array(x: object, name: str, shape: Sequence[int | str | None],
             limit: float | None = None) -> np.ndarray:
    """``x`` as a finite float64 array of ``shape`` (ints, None = any, strings = equal sizes),
    entries of magnitude <= ``limit`` when given."""
    return _checks.as_shaped(x, name, shape, _ERRORS, limit)


def as_scalar(x: object, name: str, minimum: float | None = None,
              strictly_positive: bool = False, maximum: float | None = None) -> float:
    """``x`` as a finite float, checking ``x >= minimum`` or ``x > 0``, and ``x <= maximum``."""
    return _checks.as_scalar(x, name, minimum=minimum, maximum=maximum,
                             strictly_positive=strictly_positive, error=_ERRORS)


def as_bool(x: object, name: str) -> bool:
    """``x`` as a bool: True / False (numpy bools included); anything else is refused."""
    if not isinstance(x, (bool, np.bool_)):
        raise InvalidParameterError(f"{name}: expected True or False, got {x!r:.60}")
    return bool(x)


def as_count(x: object, name: str, minimum: int = 1) -> int:
    """``x`` as an int >= ``minimum`` (bools and non-integral numbers rejected)."""
    return _checks.as_count(x, name, minimum, _ERRORS)


def as_time(x: object, name: str, length: int | None = None) -> np.ndarray:
    """A strictly increasing finite time vector (T,) in seconds."""
    return _checks.as_time(x, name, length, _ERRORS)
