"""Errors raised by the scenes package (all subclasses of ValueError)."""
from __future__ import annotations


class ScenesError(ValueError):
    """Base class of every error raised by :mod:`scenes` on bad input."""


class InvalidArgumentError(ScenesError):
    """An argument has the wrong shape, type, or contains NaN/inf."""


class InvalidObstacleError(ScenesError):
    """An obstacle has a non-positive size or radius, or a bad centre/axis/rotation."""


class SceneFileError(ScenesError):
    """A scene JSON file is malformed; the message names the field and obstacle index."""


class InvalidDemonstrationsError(ScenesError):
    """Demonstration arrays are inconsistent (rank, shape, NaN/inf, count, time order)."""


class DemonstrationFileError(ScenesError):
    """A demonstration file (.mat, .npz, .csv) cannot be read or has the wrong content."""


class UnknownSkillError(ScenesError):
    """A synthetic skill name is not one of :data:`scenes.SKILLS`."""
