"""Input checks for the robots package: arrays of joint values and points, random generators."""
from __future__ import annotations

import numpy as np

from .errors import InvalidArrayError, RobotError


def as_array(value, name: str, last_dims: tuple[int, ...], max_leading: int | None = None) -> np.ndarray:
    """Return `value` as a finite float64 array whose trailing shape is `last_dims`.

    `max_leading` bounds the number of leading (batch) dimensions; None allows any number.
    Raises InvalidArrayError naming `name` on a wrong shape or NaN/inf entries.
    """
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidArrayError(f"{name}: expected a numeric array, got {type(value).__name__}") from exc
    dims = ", ".join(str(d) for d in last_dims)
    if max_leading == 0:
        expected = f"({dims},)" if len(last_dims) == 1 else f"({dims})"
    elif max_leading == 1:
        expected = f"({dims},) or (T, {dims})"
    else:
        expected = f"(..., {dims})"
    k = len(last_dims)
    if array.ndim < k or array.shape[array.ndim - k:] != tuple(last_dims):
        raise InvalidArrayError(f"{name}: expected shape {expected}, got {array.shape}")
    if max_leading is not None and array.ndim - k > max_leading:
        raise InvalidArrayError(f"{name}: expected shape {expected}, got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise InvalidArrayError(f"{name}: contains NaN or inf values")
    return array


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
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is None:
        return np.random.default_rng(default_seed)
    if isinstance(rng, (int, np.integer)) and not isinstance(rng, bool):
        return np.random.default_rng(int(rng))
    raise error(f"rng: expected a numpy Generator, an int seed or None, got {type(rng).__name__}")
