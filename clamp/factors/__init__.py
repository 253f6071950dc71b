"""Factor families of the CLAMP planner, one module per family (see :mod:`clamp.factors.family`).

A new family is one file with a :class:`Family` subclass; pass an instance in
``clamp.plan(extra_factors=[...])`` (or add it to :func:`clamp.planner._families` for a
built-in one).
"""
from .ee_position import EEPositionFamily
from .family import Family, Linearization, square_root_information
from .joint_gp import JointGPFamily, joint_gp_covariance, joint_gp_transition
from .joint_limits import JointLimitFamily
from .joint_target import JointTargetFamily
from .obstacle import DistanceQuery, ObstacleFamily
from .orientation import OrientationFamily
from .posture import PostureFamily
from .self_collision import SelfCollisionFamily
from .states import StateWindow
from .workspace_gp import WorkspaceGPFamily
from .workspace_start import WorkspaceStartFamily, shifted_start_mean

__all__ = [
    "Family", "Linearization", "StateWindow", "square_root_information",
    "WorkspaceGPFamily", "WorkspaceStartFamily", "shifted_start_mean",
    "JointGPFamily", "joint_gp_transition", "joint_gp_covariance",
    "JointTargetFamily", "EEPositionFamily", "ObstacleFamily", "DistanceQuery",
    "JointLimitFamily", "OrientationFamily", "PostureFamily", "SelfCollisionFamily",
]
