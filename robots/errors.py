"""Errors raised by the robots package; every one derives from the project's root input error
``skillplan.errors.InvalidArgumentError`` (a ValueError)."""
from __future__ import annotations

from collections.abc import Iterable

from skillplan.errors import ArgumentTypeError, InvalidArgumentError


class RobotError(InvalidArgumentError):
    """Base class for bad input to the robots package."""


class RobotTypeError(RobotError, ArgumentTypeError):
    """An argument of the wrong kind altogether (e.g. a list where a name is expected): a
    RobotError and the project's :class:`skillplan.errors.ArgumentTypeError` (a TypeError)."""


class UnknownRobotError(RobotError):
    """A built-in robot name that does not exist."""

    def __init__(self, name: str, valid: Iterable[str]):
        self.name = name
        self.valid = tuple(valid)
        super().__init__(f"unknown robot {name!r}; available robots: {', '.join(self.valid)}")


class UnknownFrameError(RobotError):
    """A frame (link) name that the robot model does not contain."""

    def __init__(self, argument: str, name: str, valid: Iterable[str]):
        self.name = name
        self.valid = tuple(valid)
        super().__init__(f"{argument}: unknown frame {name!r}; valid frames: {', '.join(self.valid)}")


class URDFParseError(RobotError):
    """A URDF file that is missing or that Pinocchio cannot parse."""


class UnsupportedJointError(RobotError):
    """A joint type the kinematics cannot handle (only revolute, continuous, prismatic)."""


class InvalidArrayError(RobotError):
    """An array argument with the wrong shape or non-finite values."""


class SphereFileError(RobotError):
    """A collision-sphere file that is missing or malformed."""


class CollisionGeometryError(RobotError):
    """Collision geometry that cannot be read or sampled, or bad sphere-fitting settings."""


class TrajectoryError(RobotError):
    """A joint trajectory with inconsistent shapes, times or header fields."""


class TrajectoryFileError(TrajectoryError):
    """A trajectory file that cannot be written, read or parsed."""


class TrajectoryExistsError(TrajectoryFileError, FileExistsError):
    """The output file exists and overwrite=False."""


class RetimingError(RobotError):
    """Bad retiming input (limits, method, joint names) or a parameterisation that failed."""


class CollisionCheckError(RobotError):
    """Bad input to the trajectory collision checker (robots.collision_check): obstacles,
    trajectory, time stamps, margin or motion bound."""
