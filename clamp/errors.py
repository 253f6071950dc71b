"""Error hierarchy of the ``clamp`` package.

Every error raised on bad user input derives from :class:`ClampError`, itself derived from
the project's root input error ``skillplan.errors.InvalidArgumentError`` (a ``ValueError``), so
callers can catch one class. Messages name the offending argument and
state what was expected. Add new classes here (additively); do not rename existing ones.
"""
from __future__ import annotations

from skillplan.errors import ArgumentTypeError, InvalidArgumentError


class ClampError(InvalidArgumentError):
    """Base class of every error the ``clamp`` package raises on bad input."""


class ClampTypeError(ClampError, ArgumentTypeError):
    """An argument of the wrong kind altogether (e.g. a list where a name is expected): a
    ClampError and the project's :class:`skillplan.errors.ArgumentTypeError` (a TypeError)."""


class ShapeError(ClampError):
    """An array argument has the wrong number of dimensions or the wrong size."""


class NonFiniteError(ClampError):
    """An array argument contains NaN or infinite values."""


class InvalidParameterError(ClampError):
    """A scalar parameter is out of range (negative ridge, non-positive count, ...)."""


class InsufficientDemonstrationsError(ClampError):
    """Too few demonstrations to learn the requested model."""


class DegenerateDemonstrationsError(InsufficientDemonstrationsError):
    """The demonstrations do not vary at some step (identical demonstrations): a prior learned
    from them would claim certainty it does not have."""


class PriorFileError(ClampError):
    """A saved prior file is missing, unreadable or inconsistent."""


class ClampWarning(UserWarning):
    """A learning or planning setting is legal but likely to give a poor result."""


class AnimationError(ClampError):
    """Bad input to the animation writer, or a viewer dependency that is missing."""
