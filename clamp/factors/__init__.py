"""Factor families of the CLAMP planner, one module per family (see :mod:`clamp.factors.family`).

A new family is one file with a :class:`Family` subclass; pass an instance in
``clamp.plan(extra_factors=[...])`` (or add it to :func:`clamp.planning.assembly.planner_families` for
a built-in one). A constraint family (``role = "constraint"``: a hinge max(0, g + shift), see
:mod:`clamp.factors.family`) is handled by the augmented-Lagrangian solve of
:mod:`clamp.optim.constrained` when the verdict finds it violated (a ``violation(robot, q)`` method
says so); one that should join only once its check fails is one entry of the ``lazy`` mapping
in :func:`clamp.planning.pipeline.solve` (as self-collision does).
"""
from .ee_position import EEPositionFamily
from .family import Family, Linearization, square_root_information
from .joint_gp import JointGPFamily, joint_gp_covariance, joint_gp_transition
from .joint_limits import JointLimitFamily
from .joint_target import JointTargetFamily
from .obstacle import DistanceQuery, ObstacleFamily
from .orientation import OrientationFamily
from .posture import PostureFamily
from .posture_motion import PostureMotionFamily
from .posture_velocity import PostureVelocityFamily
from .self_collision import SelfCollisionFamily
from .skill_tube import SkillTubeFamily
from .states import StateWindow
from .workspace_gp import WorkspaceGPFamily
from .workspace_start import WorkspaceStartFamily, shifted_start_mean

__all__ = [
    "Family", "Linearization", "StateWindow", "square_root_information",
    "WorkspaceGPFamily", "WorkspaceStartFamily", "shifted_start_mean",
    "JointGPFamily", "joint_gp_transition", "joint_gp_covariance",
    "JointTargetFamily", "EEPositionFamily", "ObstacleFamily", "DistanceQuery",
    "JointLimitFamily", "OrientationFamily", "PostureFamily", "PostureMotionFamily", "PostureVelocityFamily", "SelfCollisionFamily",
    "SkillTubeFamily",
]
