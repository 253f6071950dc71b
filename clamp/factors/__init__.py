"""GTSAM factors of the CLAMP planner, one module per factor family.

Each family has a pure vectorized numpy residual function over all support states and a thin
GTSAM adapter built on :class:`clamp.factors.evaluation.TrajectoryEvaluator`.
"""
from .endpoint import ee_position_factors, ee_position_residuals, joint_position_factor
from .evaluation import Residuals, TrajectoryEvaluator, WorkspaceStates, workspace_states
from .joint_gp import joint_gp_covariance, joint_gp_factors, joint_gp_residuals, joint_gp_transition
from .joint_limits import joint_limit_factors, joint_limit_residuals
from .obstacle import obstacle_factors, obstacle_residuals
from .workspace_gp import workspace_gp_factors, workspace_gp_residuals
from .workspace_start import shifted_start_mean, workspace_start_factor, workspace_start_residuals

__all__ = [
    "Residuals", "TrajectoryEvaluator", "WorkspaceStates", "workspace_states",
    "workspace_gp_factors", "workspace_gp_residuals",
    "workspace_start_factor", "workspace_start_residuals", "shifted_start_mean",
    "joint_gp_factors", "joint_gp_residuals", "joint_gp_transition", "joint_gp_covariance",
    "ee_position_factors", "ee_position_residuals", "joint_position_factor",
    "obstacle_factors", "obstacle_residuals",
    "joint_limit_factors", "joint_limit_residuals",
]
