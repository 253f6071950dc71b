"""Kinematics of real arms: Pinocchio models, joint limits, end effector, collision spheres,
vectorized forward kinematics with Jacobians, and inverse kinematics for initialisation."""
from .errors import (CollisionGeometryError, InvalidArrayError, RobotError, SphereFileError,
                     UnknownFrameError, UnknownRobotError, UnsupportedJointError, URDFParseError)
from .ik import IKResult, IKTrajectoryResult
from .kinematics import EndEffectorKinematics
from .robot import Robot
from .sphere_model import SphereModel
from .registry import available_robots, load_robot

__all__ = [
    "Robot", "load_robot", "available_robots", "EndEffectorKinematics", "SphereModel",
    "IKResult", "IKTrajectoryResult",
    "RobotError", "UnknownRobotError", "UnknownFrameError", "URDFParseError", "UnsupportedJointError",
    "InvalidArrayError", "SphereFileError", "CollisionGeometryError",
]

