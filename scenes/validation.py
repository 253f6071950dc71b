"""Small shared input checks: convert to float arrays and raise clear errors.

``error`` may be any ValueError subclass, so packages that build on scenes (tlgc) reuse these
checks with their own error classes.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .errors import InvalidArgumentError


def as_array(x: Any, name: str, error: type[ValueError] = InvalidArgumentError) -> np.ndarray:
    """Float64 array of ``x``; raise ``error`` naming ``name`` if not numeric or not finite."""
    try:
        arr = np.asarray(x, dtype=float)
    except (TypeError, ValueError) as exc:
        raise error(f"{name}: expected a numeric array, got {type(x).__name__} ({exc})") from None
    if not np.all(np.isfinite(arr)):
        bad = int(np.size(arr) - np.count_nonzero(np.isfinite(arr)))
        raise error(f"{name}: contains {bad} NaN/inf value(s); expected finite numbers")
    return arr


def as_points(x: Any, name: str, error: type[ValueError] = InvalidArgumentError) -> np.ndarray:
    """Points of shape (..., 3) in metres as a finite float64 array."""
    arr = as_array(x, name, error)
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise error(f"{name}: expected shape (..., 3), got {arr.shape}")
    return arr


def as_vector(x: Any, name: str, length: int,
              error: type[ValueError] = InvalidArgumentError) -> np.ndarray:
    """A finite float64 vector of shape (length,)."""
    arr = as_array(x, name, error)
    if arr.shape != (length,):
        raise error(f"{name}: expected shape ({length},), got {arr.shape}")
    return arr


def as_positive(x: Any, name: str, error: type[ValueError] = InvalidArgumentError) -> float:
    """A finite, strictly positive scalar."""
    arr = as_array(x, name, error)
    if arr.shape != () or not arr > 0:
        raise error(f"{name}: expected a positive number, got {x!r}")
    return float(arr)


def as_count(x: Any, name: str, minimum: int = 1,
             error: type[ValueError] = InvalidArgumentError) -> int:
    """An integer >= ``minimum`` (bools rejected)."""
    if isinstance(x, bool) or not isinstance(x, (int, np.integer)) or x < minimum:
        raise error(f"{name}: expected an integer >= {minimum}, got {x!r}")
    return int(x)


def as_bounds(x: Any, name: str = "bounds",
              error: type[ValueError] = InvalidArgumentError) -> np.ndarray:
    """Axis-aligned box (2,3) [[xmin,ymin,zmin],[xmax,ymax,zmax]] with min < max."""
    arr = as_array(x, name, error)
    if arr.shape != (2, 3):
        raise error(f"{name}: expected shape (2, 3) [[xmin,ymin,zmin],[xmax,ymax,zmax]], got {arr.shape}")
    if not np.all(arr[0] < arr[1]):
        raise error(f"{name}: expected min < max on every axis, got min {arr[0]} max {arr[1]}")
    return arr
