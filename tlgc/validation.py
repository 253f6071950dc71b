"""Small input checks for tlgc: the shared checks of skillplan.validation, raising TLGC errors."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from skillplan import validation as _checks

from .errors import TLGCArgumentError, TLGCError


def as_array(x: Any, name: str, error: type[TLGCError] = TLGCArgumentError) -> np.ndarray:
    """Finite float64 array of ``x``; raise ``error`` naming ``name`` otherwise."""
    return _checks.as_array(x, name, error)


def as_points(x: Any, name: str, error: type[TLGCError] = TLGCArgumentError) -> np.ndarray:
    """Finite points of shape (..., 3) in metres, |coordinate| <= skillplan.validation.MAX_COORDINATE."""
    return _checks.as_trailing(x, name, (3,), None, error, _checks.MAX_COORDINATE)


def as_trailing(x: Any, name: str, last_dims: tuple[int, ...],
                error: type[TLGCError] = TLGCArgumentError) -> np.ndarray:
    """Finite array of shape (..., *last_dims)."""
    return _checks.as_trailing(x, name, last_dims, None, error)


def as_indices(x: Any, name: str) -> np.ndarray:
    """Non-negative integer indices (K,) as an intp array."""
    return _checks.as_indices(x, name, TLGCArgumentError)


def as_bool(x: Any, name: str) -> bool:
    """True or False (numpy bools included); TLGCArgumentError otherwise."""
    return _checks.as_bool(x, name, TLGCArgumentError)


def as_path(x: Any, name: str = "path") -> Path:
    """A file path (str or os.PathLike); TLGCArgumentError otherwise."""
    return _checks.as_path(x, name, TLGCArgumentError)


def as_file(x: Any, error: type[TLGCError], name: str = "path") -> Path:
    """An existing regular file (``error`` for a missing path or a directory)."""
    return _checks.as_file(x, name, error, TLGCArgumentError)


def as_scalar(x: Any, name: str, minimum: float | None = None, maximum: float | None = None,
              error: type[TLGCError] = TLGCArgumentError) -> float:
    """A finite scalar within [minimum, maximum] (either bound optional)."""
    return _checks.as_scalar(x, name, minimum, maximum, error=error)


def as_count(x: Any, name: str, minimum: int = 1,
             error: type[TLGCError] = TLGCArgumentError) -> int:
    """An integer >= ``minimum`` (bools rejected)."""
    return _checks.as_count(x, name, minimum, error)


def as_generator(rng: Any, name: str = "rng") -> np.random.Generator:
    """A numpy Generator from a Generator or an integer seed."""
    return _checks.as_generator(rng, name, error=TLGCArgumentError)
