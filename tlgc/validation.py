"""Small input checks for tlgc: the shared checks of scenes.validation, raising TLGC errors."""
from __future__ import annotations

from typing import Any

import numpy as np

from scenes import validation as _checks

from .errors import InvalidArgumentError, TLGCError


def as_array(x: Any, name: str, error: type[TLGCError] = InvalidArgumentError) -> np.ndarray:
    """Finite float64 array of ``x``; raise ``error`` naming ``name`` otherwise."""
    return _checks.as_array(x, name, error)


def as_points(x: Any, name: str, error: type[TLGCError] = InvalidArgumentError) -> np.ndarray:
    """Finite points of shape (..., 3) in metres."""
    return _checks.as_points(x, name, error)


def as_scalar(x: Any, name: str, minimum: float | None = None, maximum: float | None = None,
              error: type[TLGCError] = InvalidArgumentError) -> float:
    """A finite scalar within [minimum, maximum] (either bound optional)."""
    arr = as_array(x, name, error)
    if arr.shape != ():
        raise error(f"{name}: expected a number, got shape {arr.shape}")
    value = float(arr)
    if (minimum is not None and value < minimum) or (maximum is not None and value > maximum):
        lo = "-inf" if minimum is None else f"{minimum:g}"
        hi = "inf" if maximum is None else f"{maximum:g}"
        raise error(f"{name}: expected a number in [{lo}, {hi}], got {value!r}")
    return value


def as_count(x: Any, name: str, minimum: int = 1,
             error: type[TLGCError] = InvalidArgumentError) -> int:
    """An integer >= ``minimum`` (bools rejected)."""
    return _checks.as_count(x, name, minimum, error)


def as_generator(rng: Any, name: str = "rng") -> np.random.Generator:
    """A numpy Generator from a Generator or an integer seed."""
    if isinstance(rng, np.random.Generator):
        return rng
    if isinstance(rng, (int, np.integer)) and not isinstance(rng, bool):
        return np.random.default_rng(int(rng))
    raise InvalidArgumentError(
        f"{name}: expected a numpy.random.Generator or an integer seed, got {type(rng).__name__}")
