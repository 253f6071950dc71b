# The public names of robots, read by static type checkers and, at run time, by
# lazy_loader.attach_stub in __init__.py (each submodule is imported on first use).
from .errors import (CollisionGeometryError, InvalidArrayError, RetimingError, RobotError,
                     SphereFileError, TrajectoryError, TrajectoryExistsError, TrajectoryFileError,
                     UnknownFrameError, UnknownRobotError, UnsupportedJointError, URDFParseError)
from .ik import IKResult, IKTrajectoryResult, PoseIKResult
from .kinematics import EndEffectorKinematics
from .robot import Robot
from .sphere_model import SphereModel
from .registry import available_robots, load_robot, resolve_robot
from .retiming import RetimingReport, check_limits, retime, uniform_scaling
from .self_collision import SelfCollisionReport, disabled_pairs, self_collision_report
from .trajectory import JointTrajectory, RetimingLimits, load_trajectory

__all__ = [
    "Robot", "load_robot", "resolve_robot", "available_robots", "EndEffectorKinematics", "SphereModel",
    "IKResult", "IKTrajectoryResult", "PoseIKResult", "JointTrajectory", "RetimingLimits",
    "load_trajectory", "retime",
    "RetimingReport", "check_limits", "uniform_scaling",
    "self_collision_report", "SelfCollisionReport", "disabled_pairs",
    "RobotError", "UnknownRobotError", "UnknownFrameError", "URDFParseError", "UnsupportedJointError",
    "InvalidArrayError", "SphereFileError", "CollisionGeometryError", "TrajectoryError",
    "TrajectoryFileError", "TrajectoryExistsError", "RetimingError",
]

