"""Errors raised by the tlgc package on bad input (all derive from the project's root input
error ``skillplan.errors.InvalidArgumentError``, a ValueError).

Other tlgc modules may add subclasses here; every message names the offending argument and
what was expected.
"""
from __future__ import annotations

from skillplan import errors as _project


class TLGCError(_project.InvalidArgumentError):
    """Base class of every error raised by :mod:`tlgc` on bad input."""


class TLGCArgumentError(TLGCError):
    """An argument has the wrong type, shape or value, or contains NaN/inf."""


class CylinderDemonstrationsError(TLGCError):
    """Demonstrations have the wrong shape, contain NaN/inf, or are degenerate."""


class TooFewDemonstrationsError(CylinderDemonstrationsError):
    """Fewer demonstrations than a generalized cylinder needs (at least 2)."""


class UnknownCrossSectionError(TLGCError):
    """A cross-section type name is not one of :data:`tlgc.cross_sections.CROSS_SECTION_TYPES`."""


class StartOutsideError(TLGCError):
    """A reproduction start lies outside the first cross-section (ratio > 1)."""


class StartOffPlaneError(StartOutsideError):
    """A reproduction start lies farther than the stated tolerance from the first section's
    plane (before or past it); it is refused rather than projected onto the plane."""


class GeneralizationError(TLGCError):
    """A generalization cannot be done as asked (e.g. it would deform the skill beyond the
    stated bound, or move a start that is to be kept)."""


class ObstacleAvoidanceError(TLGCError):
    """The obstacle cannot be avoided by the requested strategy (e.g. it blocks the cylinder
    along a start's direction); the message names the start when there is one."""


class CylinderFileError(TLGCError):
    """A saved generalized-cylinder file cannot be read or has the wrong content."""
