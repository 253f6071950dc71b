"""Input checks for the robots package (arrays of joint values and points, random generators):
the project's checks (:mod:`skillplan.validation`) raising robots errors."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from skillplan import validation as _checks

from .errors import RobotTypeError, InvalidArrayError, RobotError


def as_array(value, name: str, last_dims: tuple[int, ...], max_leading: int | None = None) -> np.ndarray:
    """Return `value` as a finite float64 array whose trailing shape is `last_dims`, with at most
    `max_leading` leading (batch) dimensions (None: any); InvalidArrayError naming `name`."""
    return _checks.as_trailing(value, name, last_dims, max_leading, InvalidArrayError)


def as_joint_array(q, name: str, n: int) -> np.ndarray:
    """Joint values of shape (..., n), finite, float64."""
    return as_array(q, name, (n,))


def as_point(x, name: str) -> np.ndarray:
    """One point (3,) in metres, finite, float64."""
    return as_array(x, name, (3,), max_leading=0)


def as_points(x, name: str) -> np.ndarray:
    """Points (T, 3) in metres, finite, float64."""
    array = as_array(x, name, (3,), max_leading=1)
    if array.ndim != 2:
        raise InvalidArrayError(f"{name}: expected shape (T, 3), got {array.shape}")
    return array


def as_generator(rng, error: type[RobotError] = RobotError, default_seed: int = 0) -> np.random.Generator:
    """A numpy Generator as is; an int seed -> default_rng(seed); None -> default_rng(default_seed).

    Anything else (bools included) raises `error` naming the argument rng.
    """
    return _checks.as_generator(rng, "rng", default_seed, error)


def as_scalar(x, name: str, minimum: float | None = None, error: type[RobotError] = RobotError) -> float:
    """A finite real number >= ``minimum`` (bools refused); `error` naming `name`."""
    return _checks.as_scalar(x, name, minimum=minimum, error=error)


def as_file(path, name: str, error: type[RobotError]) -> Path:
    """An existing regular file (`error` for a missing path or a directory, RobotTypeError
    for something that is not a path)."""
    return _checks.as_file(path, name, error, RobotTypeError)
