"""Input checks of the ``clamp`` modules: the project's checks (:mod:`skillplan.validation`)
raising :mod:`clamp.errors` classes (ShapeError, NonFiniteError, InvalidParameterError)."""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from clamp.errors import InvalidParameterError, NonFiniteError, ShapeError
from skillplan import validation as _checks

#: the clamp error classes, for calling :mod:`skillplan.validation` checks without a wrapper here
ERRORS = _checks.ErrorKinds(ShapeError, NonFiniteError, InvalidParameterError)


def as_array(x: object, name: str, shape: Sequence[int | str | None],
             limit: float | None = None, allow_infinite: bool = False) -> np.ndarray:
    """``x`` as a finite float64 array of ``shape`` (ints, None = any, strings = equal sizes),
    entries of magnitude <= ``limit`` when given (+-inf accepted with ``allow_infinite``)."""
    return _checks.as_shaped(x, name, shape, ERRORS, limit, allow_infinite)


def as_indices(x: object, name: str) -> np.ndarray:
    """Non-negative integer support-state indices (K,) as an intp array."""
    return _checks.as_indices(x, name, ERRORS)


def is_symmetric(cov: np.ndarray) -> bool:
    """Whether a stack (..., D, D) is symmetric to 1e-9 of its largest entry."""
    if not cov.size:
        return True
    scale = max(float(np.max(np.abs(cov))), 1e-300)
    return bool(np.max(np.abs(cov - np.swapaxes(cov, -1, -2))) <= 1e-9 * scale)


def cholesky(cov: np.ndarray, name: str, hint: str = "") -> np.ndarray:
    """Lower Cholesky factors of a stack (..., D, D) of covariances; InvalidParameterError
    naming the worst matrix and its smallest eigenvalue when one is not positive definite."""
    try:
        return np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        flat = cov.reshape(-1, *cov.shape[-2:])
        smallest = np.linalg.eigvalsh(flat)[:, 0]
        worst = int(np.argmin(smallest))
        where = f"{name}[{worst}]" if cov.ndim > 2 else name
        raise InvalidParameterError(
            f"{name}: expected positive definite covariances; {where} has smallest eigenvalue "
            f"{smallest[worst]:.3g}{hint}") from None


def as_covariance(x: object, name: str, shape: Sequence[int | str | None],
                  positive_definite: bool = True) -> np.ndarray:
    """``x`` as a finite array of ``shape`` (last two axes square) of symmetric covariance
    matrices, positive definite (checked by a Cholesky factorisation) unless the caller checks
    that itself (``positive_definite=False``)."""
    cov = as_array(x, name, shape)
    if not is_symmetric(cov):
        raise InvalidParameterError(f"{name}: expected symmetric covariance matrices")
    if positive_definite:
        cholesky(cov, name)
    return cov


def as_scalar(x: object, name: str, minimum: float | None = None,
              strictly_positive: bool = False, maximum: float | None = None) -> float:
    """``x`` as a finite float, checking ``x >= minimum`` or ``x > 0``, and ``x <= maximum``."""
    return _checks.as_scalar(x, name, minimum=minimum, maximum=maximum,
                             strictly_positive=strictly_positive, error=ERRORS)


def as_bool(x: object, name: str) -> bool:
    """``x`` as a bool: True / False (numpy bools included); anything else is refused."""
    return _checks.as_bool(x, name, ERRORS)


def as_count(x: object, name: str, minimum: int = 1) -> int:
    """``x`` as an int >= ``minimum`` (bools and non-integral numbers rejected)."""
    return _checks.as_count(x, name, minimum, ERRORS)


def as_time(x: object, name: str, length: int | None = None) -> np.ndarray:
    """A strictly increasing finite time vector (T,) in seconds."""
    return _checks.as_time(x, name, length, ERRORS)
