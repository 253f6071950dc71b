"""Small input-checking helpers shared by the ``clamp`` modules.

Each helper converts its argument to a float64 numpy array (or a Python scalar) and raises a
:mod:`clamp.errors` exception naming the argument and what was expected.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from clamp.errors import InvalidParameterError, NonFiniteError, ShapeError


def _describe(shape: Sequence[int | str | None]) -> str:
    return "(" + ", ".join("*" if s is None else str(s) for s in shape) + ")"


def as_array(x: object, name: str, shape: Sequence[int | str | None]) -> np.ndarray:
    """Return ``x`` as a finite float64 array of the given shape.

    ``shape`` entries are ints (exact size), None (any size) or strings (symbolic sizes that
    must agree between the entries carrying the same string, e.g. ``("D", "D")``).
    Raises ShapeError / NonFiniteError naming ``name``.
    """
    try:
        arr = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ShapeError(f"{name}: expected a numeric array of shape {_describe(shape)}, "
                         f"got {type(x).__name__} ({exc})") from None
    if arr.ndim != len(shape):
        raise ShapeError(f"{name}: expected an array of shape {_describe(shape)}, "
                         f"got shape {arr.shape}")
    symbols: dict[str, int] = {}
    for axis, (want, got) in enumerate(zip(shape, arr.shape)):
        if isinstance(want, str):
            if symbols.setdefault(want, got) != got:
                raise ShapeError(f"{name}: expected shape {_describe(shape)} with equal sizes "
                                 f"for '{want}', got shape {arr.shape}")
        elif want is not None and want != got:
            raise ShapeError(f"{name}: expected shape {_describe(shape)}, got shape {arr.shape} "
                             f"(axis {axis} should be {want})")
    if not np.all(np.isfinite(arr)):
        bad = int(np.size(arr) - np.count_nonzero(np.isfinite(arr)))
        raise NonFiniteError(f"{name}: expected finite values, found {bad} NaN/inf entries")
    return arr


def as_scalar(x: object, name: str, minimum: float | None = None,
              strictly_positive: bool = False) -> float:
    """Return ``x`` as a finite float, checking ``x >= minimum`` or ``x > 0``."""
    try:
        value = float(x)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{name}: expected a real number, got {x!r}") from None
    if not np.isfinite(value):
        raise InvalidParameterError(f"{name}: expected a finite number, got {value}")
    if strictly_positive and value <= 0:
        raise InvalidParameterError(f"{name}: expected a positive number, got {value}")
    if minimum is not None and value < minimum:
        raise InvalidParameterError(f"{name}: expected a number >= {minimum}, got {value}")
    return value


def as_count(x: object, name: str, minimum: int = 1) -> int:
    """Return ``x`` as an int >= ``minimum`` (bools and non-integral floats rejected)."""
    if isinstance(x, bool) or not isinstance(x, (int, np.integer)):
        raise InvalidParameterError(f"{name}: expected an integer >= {minimum}, got {x!r}")
    if int(x) < minimum:
        raise InvalidParameterError(f"{name}: expected an integer >= {minimum}, got {x}")
    return int(x)


def as_time(x: object, name: str, length: int | None = None) -> np.ndarray:
    """Return a strictly increasing finite time vector (T,) in seconds."""
    t = as_array(x, name, (length,))
    if t.size < 2:
        raise ShapeError(f"{name}: expected at least 2 time stamps, got {t.size}")
    if np.any(np.diff(t) <= 0):
        raise InvalidParameterError(f"{name}: expected strictly increasing time stamps")
    return t
