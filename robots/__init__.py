"""Kinematics of real arms: Pinocchio models, joint limits, end effector, collision spheres,
vectorized forward kinematics with Jacobians, and inverse kinematics for initialisation."""
from .errors import (InvalidArrayError, RobotError, SphereFileError, UnknownFrameError,
                     UnknownRobotError, UnsupportedJointError, URDFParseError)
from .kinematics import EndEffectorKinematics
from .robot import Robot
from .sphere_model import SphereModel
from .registry import available_robots, load_robot

__all__ = [
    "Robot", "load_robot", "available_robots", "EndEffectorKinematics", "SphereModel",
    "IKResult", "IKTrajectoryResult",
    "RobotError", "UnknownRobotError", "UnknownFrameError", "URDFParseError", "UnsupportedJointError",
    "InvalidArrayError", "SphereFileError",
]


def __getattr__(name):
    # the IK results live in a module imported on first use
    if name in ("IKResult", "IKTrajectoryResult"):
        from . import ik
        return getattr(ik, name)
    raise AttributeError(f"module 'robots' has no attribute {name!r}")
