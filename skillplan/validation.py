"""The project's one argument-validation helper: convert inputs and raise clear errors.

Every check names the argument, what was expected and what was given. ``error`` is the class
to raise — any subclass of the project's root :class:`~scenes.errors.InvalidArgumentError`
(each package passes its own) — or an :class:`ErrorKinds` triple when a package distinguishes
wrong shapes, non-finite values and out-of-range values (``clamp``). ``robots``, ``clamp`` and
``tlgc`` keep thin wrappers that fix their error classes; the checks themselves live here.
"""
from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple, Union

import numpy as np

from .errors import InvalidArgumentError


class ErrorKinds(NamedTuple):
    """The classes raised for a wrong shape / type, for NaN or inf, and for a bad value."""

    shape: type[ValueError]
    nonfinite: type[ValueError]
    value: type[ValueError]


Errors = Union[type[ValueError], ErrorKinds]


#: Largest magnitude accepted where a caller asks for a ``limit`` on coordinates: positions and
#: sizes [m], velocities [m/s]. 1000 km: far beyond any arm, far below float overflow in squares.
MAX_COORDINATE = 1e6


def _kinds(error: Errors) -> ErrorKinds:
    return error if isinstance(error, ErrorKinds) else ErrorKinds(error, error, error)


def _has_bool(x: Any) -> bool:
    """True when ``x`` holds a Python / numpy bool (numpy would read it silently as 0 / 1)."""
    if isinstance(x, (bool, np.bool_)):
        return True
    if isinstance(x, np.ndarray):
        return x.dtype == bool or (x.dtype == object and any(_has_bool(e) for e in x.flat))
    if isinstance(x, (list, tuple)):
        return any(_has_bool(e) for e in x)
    return False


def _numeric(x: Any, name: str, error: Errors, expected: str = "a numeric array") -> np.ndarray:
    if _has_bool(x):
        raise _kinds(error).shape(f"{name}: expected {expected}, got booleans (True/False are "
                                  "not numbers here)")
    if isinstance(x, (str, bytes, dict, set)) or x is None:
        raise _kinds(error).shape(f"{name}: expected {expected}, got {type(x).__name__} {x!r:.60}")
    try:
        return np.asarray(x, dtype=float)
    except (TypeError, ValueError) as exc:
        raise _kinds(error).shape(f"{name}: expected {expected}, got {type(x).__name__} "
                                  f"({exc})") from None


def _finite(arr: np.ndarray, name: str, error: Errors, limit: float | None = None,
            allow_infinite: bool = False) -> np.ndarray:
    if allow_infinite:
        if np.any(np.isnan(arr)):
            raise _kinds(error).nonfinite(f"{name}: contains {int(np.isnan(arr).sum())} NaN "
                                          "value(s); expected numbers (+-inf allowed)")
    elif not np.all(np.isfinite(arr)):
        bad = int(np.size(arr) - np.count_nonzero(np.isfinite(arr)))
        raise _kinds(error).nonfinite(f"{name}: contains {bad} NaN/inf value(s); expected "
                                      "finite numbers")
    if limit is not None and arr.size and float(np.max(np.abs(arr))) > limit:
        raise _kinds(error).value(f"{name}: expected values of magnitude <= {limit:g}, got "
                                  f"{float(np.max(np.abs(arr))):.4g}")
    return arr


def as_array(x: Any, name: str, error: Errors = InvalidArgumentError,
             limit: float | None = None, allow_infinite: bool = False) -> np.ndarray:
    """Float64 array of ``x`` (any shape); raise ``error`` naming ``name`` if not numeric (bools
    included), not finite (+-inf accepted with ``allow_infinite``, NaN never), or (with
    ``limit``) of magnitude above ``limit``."""
    return _finite(_numeric(x, name, error), name, error, limit, allow_infinite)


def _describe(shape: Sequence[int | str | None]) -> str:
    return "(" + ", ".join("*" if s is None else str(s) for s in shape) + ")"


def as_shaped(x: Any, name: str, shape: Sequence[int | str | None],
              error: Errors = InvalidArgumentError, limit: float | None = None,
              allow_infinite: bool = False) -> np.ndarray:
    """Finite float64 array of exactly the given shape.

    ``shape`` entries are ints (exact size), None (any size) or strings (symbolic sizes that
    must agree between the entries carrying the same string, e.g. ``("D", "D")``).
    ``allow_infinite``: +-inf accepted (joint limits of continuous joints), NaN still refused.
    """
    kinds = _kinds(error)
    arr = _numeric(x, name, error, f"a numeric array of shape {_describe(shape)}")
    if arr.ndim != len(shape):
        raise kinds.shape(f"{name}: expected an array of shape {_describe(shape)}, "
                          f"got shape {arr.shape}")
    symbols: dict[str, int] = {}
    for axis, (want, got) in enumerate(zip(shape, arr.shape)):
        if isinstance(want, str):
            if symbols.setdefault(want, got) != got:
                raise kinds.shape(f"{name}: expected shape {_describe(shape)} with equal sizes "
                                  f"for '{want}', got shape {arr.shape}")
        elif want is not None and want != got:
            raise kinds.shape(f"{name}: expected shape {_describe(shape)}, got shape "
                              f"{arr.shape} (axis {axis} should be {want})")
    return _finite(arr, name, error, limit, allow_infinite)


def as_trailing(x: Any, name: str, last_dims: tuple[int, ...], max_leading: int | None = None,
                error: Errors = InvalidArgumentError, limit: float | None = None) -> np.ndarray:
    """Finite float64 array whose trailing shape is ``last_dims``, with at most
    ``max_leading`` leading (batch) dimensions (None: any number), entries of magnitude <=
    ``limit`` when given."""
    kinds = _kinds(error)
    arr = _numeric(x, name, error)
    dims = ", ".join(str(d) for d in last_dims)
    if max_leading == 0:
        expected = f"({dims},)" if len(last_dims) == 1 else f"({dims})"
    elif max_leading == 1:
        expected = f"({dims},) or (T, {dims})"
    else:
        expected = f"(..., {dims})"
    k = len(last_dims)
    if (arr.ndim < k or arr.shape[arr.ndim - k:] != tuple(last_dims)
            or (max_leading is not None and arr.ndim - k > max_leading)):
        raise kinds.shape(f"{name}: expected shape {expected}, got {arr.shape}")
    return _finite(arr, name, error, limit)


def as_points(x: Any, name: str, error: Errors = InvalidArgumentError) -> np.ndarray:
    """Points of shape (..., 3) in metres as a finite float64 array."""
    return as_trailing(x, name, (3,), None, error)


def as_vector(x: Any, name: str, length: int, error: Errors = InvalidArgumentError,
              limit: float | None = None) -> np.ndarray:
    """A finite float64 vector of shape (length,) (entries of magnitude <= ``limit``)."""
    return as_shaped(x, name, (length,), error, limit)


def as_scalar(x: Any, name: str, minimum: float | None = None, maximum: float | None = None,
              strictly_positive: bool = False, error: Errors = InvalidArgumentError) -> float:
    """A finite real number within [minimum, maximum] (either bound optional), > 0 with
    ``strictly_positive``."""
    kinds = _kinds(error)
    if isinstance(x, bool):
        raise kinds.value(f"{name}: expected a real number, got {x!r}")
    if isinstance(x, (str, bytes)):
        raise kinds.value(f"{name}: expected a real number, got the text {x!r:.60}")
    try:
        arr = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise kinds.value(f"{name}: expected a real number, got {x!r:.60}") from None
    if arr.shape != ():
        raise kinds.value(f"{name}: expected a real number, got an array of shape {arr.shape}")
    value = float(arr)
    if not np.isfinite(value):
        raise kinds.value(f"{name}: expected a finite number, got {value}")
    if strictly_positive and value <= 0:
        raise kinds.value(f"{name}: expected a positive number, got {value}")
    if (minimum is not None and value < minimum) or (maximum is not None and value > maximum):
        if maximum is None:
            expected = f">= {minimum:g}"
        elif minimum is None:
            expected = f"<= {maximum:g}"
        else:
            expected = f"in [{minimum:g}, {maximum:g}]"
        raise kinds.value(f"{name}: expected a number {expected}, got {value!r}")
    return value


def as_positive(x: Any, name: str, error: Errors = InvalidArgumentError) -> float:
    """A finite, strictly positive scalar."""
    return as_scalar(x, name, strictly_positive=True, error=error)


def as_count(x: Any, name: str, minimum: int = 1, error: Errors = InvalidArgumentError) -> int:
    """An integer >= ``minimum`` (bools and non-integral numbers rejected)."""
    if isinstance(x, bool) or not isinstance(x, (int, np.integer)) or int(x) < minimum:
        raise _kinds(error).value(f"{name}: expected an integer >= {minimum}, got {x!r}")
    return int(x)


def as_time(x: Any, name: str, length: int | None = None,
            error: Errors = InvalidArgumentError) -> np.ndarray:
    """A strictly increasing finite time vector (T,) in seconds, T >= 2, whose steps are at
    least :data:`TIME_RESOLUTION` times its span (closer stamps cannot be told apart by the
    splines and regressions downstream)."""
    kinds = _kinds(error)
    t = as_shaped(x, name, (length,), error)
    if t.size < 2:
        raise kinds.shape(f"{name}: expected at least 2 time stamps, got {t.size}")
    step = np.diff(t)
    if np.any(step <= 0):
        k = int(np.argmax(step <= 0))
        raise kinds.value(f"{name}: expected strictly increasing time stamps, but {name}[{k + 1}] "
                          f"= {t[k + 1]} <= {name}[{k}] = {t[k]}")
    span = float(t[-1] - t[0])
    if not np.isfinite(span) or np.any(step < TIME_RESOLUTION * span):
        k = int(np.argmin(step))
        raise kinds.value(f"{name}: time stamps {name}[{k}] = {t[k]} and {name}[{k + 1}] = "
                          f"{t[k + 1]} are too close to tell apart (step {step[k]:.3g} s over a "
                          f"span of {span:.4g} s; expected steps >= {TIME_RESOLUTION:g} x span)")
    return t


#: Smallest time step accepted by :func:`as_time`, relative to the span of the time vector.
TIME_RESOLUTION = 1e-9


def as_indices(x: Any, name: str, error: Errors = InvalidArgumentError) -> np.ndarray:
    """Non-negative integer indices (K,) as an intp array from a list / array of integers (a
    single integer gives (1,)); bools, fractions and text are refused."""
    kinds = _kinds(error)
    if _has_bool(x) or isinstance(x, (str, bytes, dict, set)) or x is None:
        raise kinds.shape(f"{name}: expected a list of integer indices, got "
                          f"{type(x).__name__} {x!r:.60}")
    try:
        arr = np.asarray(x)
    except (TypeError, ValueError) as exc:
        raise kinds.shape(f"{name}: expected a list of integer indices, got {type(x).__name__} "
                          f"({exc})") from None
    if arr.ndim > 1:
        raise kinds.shape(f"{name}: expected a list of integer indices (K,), got shape "
                          f"{arr.shape}")
    if arr.size and arr.dtype.kind not in "iu":
        integral = arr.dtype.kind == "f" and bool(np.all(np.isfinite(arr))) \
            and bool(np.all(arr == np.round(arr)))
        if not integral:
            raise kinds.value(f"{name}: expected integer indices, got {arr.reshape(-1)[:6]!r:.80}")
    out = arr.astype(np.intp).reshape(-1)
    if out.size and out.min() < 0:
        raise kinds.value(f"{name}: expected non-negative indices, got {int(out.min())}")
    return out


def as_generator(rng: Any, name: str = "rng", default_seed: int | None = None,
                 error: Errors = InvalidArgumentError) -> np.random.Generator:
    """A numpy Generator as is, an integer seed -> default_rng(seed), None ->
    default_rng(default_seed) when a default seed is given (else an error)."""
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is None and default_seed is not None:
        return np.random.default_rng(default_seed)
    if isinstance(rng, (int, np.integer)) and not isinstance(rng, bool):
        return np.random.default_rng(as_seed(rng, name, error))
    allowed = "a numpy Generator, a non-negative int seed or None" if default_seed is not None \
        else "a numpy.random.Generator or a non-negative integer seed"
    raise _kinds(error).value(f"{name}: expected {allowed}, got {type(rng).__name__}")


def as_bounds(x: Any, name: str = "bounds", error: Errors = InvalidArgumentError) -> np.ndarray:
    """Axis-aligned box (2,3) [[xmin,ymin,zmin],[xmax,ymax,zmax]] with min < max."""
    arr = as_array(x, name, error)
    if arr.shape != (2, 3):
        raise _kinds(error).shape(f"{name}: expected shape (2, 3) [[xmin,ymin,zmin],"
                                  f"[xmax,ymax,zmax]], got {arr.shape}")
    if not np.all(arr[0] < arr[1]):
        raise _kinds(error).value(f"{name}: expected min < max on every axis, got min {arr[0]} "
                                  f"max {arr[1]}")
    return arr


def as_seed(x: Any, name: str = "seed", error: Errors = InvalidArgumentError) -> int:
    """A random seed: an integer in [0, 2**63) (numpy's generators refuse negative seeds)."""
    if isinstance(x, bool) or not isinstance(x, (int, np.integer)) or not 0 <= int(x) < 2**63:
        raise _kinds(error).value(f"{name}: expected a non-negative integer seed, got {x!r:.60}")
    return int(x)


def as_instance(x: Any, name: str, types: type | tuple[type, ...], expected: str,
                error: type[ValueError]) -> Any:
    """``x`` itself when it is one of ``types``; else ``error`` naming ``name``, ``expected``
    and the type given (pass a package's ArgumentTypeError, a TypeError too)."""
    if not isinstance(x, types):
        raise error(f"{name}: expected {expected}, got {type(x).__name__} {x!r:.60}")
    return x


def as_sequence(x: Any, name: str, expected: str, error: type[ValueError]) -> list:
    """A list from a list / tuple / other non-text iterable (not a str, bytes, dict, set nor a
    single number); ``error`` naming ``name`` and ``expected`` otherwise."""
    if isinstance(x, (str, bytes, dict, set)) or not hasattr(x, "__iter__"):
        raise error(f"{name}: expected {expected}, got {type(x).__name__} {x!r:.60}")
    return list(x)


def as_bool(x: Any, name: str, error: Errors = InvalidArgumentError) -> bool:
    """``x`` as a bool: True / False (numpy bools included); anything else raises ``error``
    naming ``name`` (1, "yes" and None are refused, not read as truth values)."""
    if not isinstance(x, (bool, np.bool_)):
        raise _kinds(error).value(f"{name}: expected True or False, got {x!r:.60}")
    return bool(x)


def as_path(x: Any, name: str, error: type[ValueError]) -> Path:
    """A path from a str or os.PathLike (``error``, e.g. a package's ArgumentTypeError,
    otherwise)."""
    if isinstance(x, bytes) or not isinstance(x, (str, os.PathLike)):
        raise error(f"{name}: expected a file path (str or pathlib.Path), got "
                    f"{type(x).__name__} {x!r:.60}")
    return Path(x)


def as_file(x: Any, name: str, error: type[ValueError],
            type_error: type[ValueError] | None = None) -> Path:
    """An existing regular file: a directory or a missing path raise ``error`` saying which,
    a non-path ``type_error`` (default ``error``)."""
    path = as_path(x, name, type_error or error)
    if path.is_dir():
        raise error(f"{name}: {path} is a directory, expected a file")
    if not path.is_file():
        raise error(f"{name}: {path} does not exist (no such file)")
    return path


def unknown_names(unknown: Any, valid: Any) -> str:
    """The unknown keys of a file, each with the nearest valid one when there is a close one
    (``difflib``): "'sise' (did you mean 'size'?), 'colour'"."""
    import difflib
    valid = sorted(valid)
    out = []
    for name in sorted(unknown):
        close = difflib.get_close_matches(str(name), valid, n=1, cutoff=0.6)
        out.append(f"{name!r}" + (f" (did you mean {close[0]!r}?)" if close else ""))
    return ", ".join(out)
