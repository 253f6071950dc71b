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
    return _checks.as_scalar(x, name, minimum, maximum, error=error)


def as_count(x: Any, name: str, minimum: int = 1,
             error: type[TLGCError] = InvalidArgumentError) -> int:
    """An integer >= ``minimum`` (bools rejected)."""
    return _checks.as_count(x, name, minimum, error)


def as_generator(rng: Any, name: str = "rng") -> np.random.Generator:
    """A numpy Generator from a Generator or an integer seed."""
    return _checks.as_generator(rng, name, error=InvalidArgumentError)
