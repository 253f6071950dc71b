"""The project's one error hierarchy, rooted here.

:class:`InvalidArgumentError` (a ValueError) is the root of every error the four packages
raise on bad input; each package's base derives from it (``scenes.errors.ScenesError``,
``robots.errors.RobotError``, ``clamp.errors.ClampError``, ``tlgc.errors.TLGCError``), so a
caller can catch one class. The errors every package shares (an argument of the wrong kind, an
output path that cannot be used, a write that failed) live here too, once.
"""
from __future__ import annotations


class InvalidArgumentError(ValueError):
    """Root of every input error of the project: an argument has the wrong type, shape or
    value (the message names the argument, what was expected and what was given)."""


class ArgumentTypeError(InvalidArgumentError, TypeError):
    """An argument is of the wrong kind altogether (e.g. a number where a list of obstacles or a
    file path is expected); also a TypeError."""


class OutputPathError(InvalidArgumentError, FileExistsError):
    """An output file or folder cannot be used: it exists (pass overwrite=True / --force), is
    not empty, is a file where a folder is expected, or its folder is missing."""


class OutputWriteError(OSError):
    """Writing an output failed part-way (disk full, file too large, an I/O error): not bad
    input, so not an :class:`InvalidArgumentError`; the message names the user's file and
    what was kept. Command lines exit 1 on it."""
