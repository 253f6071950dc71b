"""Errors raised on bad input: the project's one hierarchy, rooted here.

:class:`InvalidArgumentError` (a ValueError) is the root of every error the four packages
raise on bad input; each package's base derives from it (``robots.errors.RobotError``,
:class:`ScenesError`, ``clamp.errors.ClampError``, ``tlgc.errors.TLGCError``), so a caller
can catch one class. ``scenes`` is the base the other packages build on, hence the root
lives here.
"""
from __future__ import annotations


class InvalidArgumentError(ValueError):
    """Root of every input error of the project: an argument has the wrong type, shape or
    value (the message names the argument, what was expected and what was given)."""


class ScenesError(InvalidArgumentError):
    """Base class of the errors specific to :mod:`scenes` (obstacles, scene files,
    demonstrations, skills)."""


class ArgumentTypeError(ScenesError, TypeError):
    """An argument is of the wrong kind altogether (e.g. a number where a list of obstacles or a
    file path is expected); also a TypeError."""


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


class OutputPathError(ScenesError, FileExistsError):
    """An output file or folder cannot be used: it exists (pass overwrite=True / --force), is
    not empty, is a file where a folder is expected, or its folder is missing."""


class OutputWriteError(OSError):
    """Writing an output failed part-way (disk full, file too large, an I/O error): not bad
    input, so not an :class:`InvalidArgumentError`; the message names the user's file and
    what was kept. Command lines exit 1 on it."""
