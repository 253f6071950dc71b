"""Errors of :mod:`scenes` (obstacles, scene files, demonstrations, skills); they derive from
the project's root input error :class:`skillplan.errors.InvalidArgumentError`."""
from __future__ import annotations

from skillplan.errors import ArgumentTypeError, InvalidArgumentError, OutputPathError, OutputWriteError

__all__ = ["ScenesTypeError", "InvalidArgumentError", "OutputPathError", "OutputWriteError",
           "ScenesError", "InvalidObstacleError", "SceneFileError", "InvalidDemonstrationsError",
           "DemonstrationFileError", "UnknownSkillError"]


class ScenesError(InvalidArgumentError):
    """Base class of the errors specific to :mod:`scenes` (obstacles, scene files,
    demonstrations, skills)."""


class ScenesTypeError(ScenesError, ArgumentTypeError):
    """An argument of the wrong kind altogether (e.g. a list where a name is expected): a
    ScenesError and the project's :class:`skillplan.errors.ArgumentTypeError` (a TypeError)."""


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
