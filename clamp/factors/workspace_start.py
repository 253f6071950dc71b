"""Workspace start factor: x(theta_0) against a Gaussian (mean (6,), covariance (6, 6)).

With the learned prior this is (mean0, cov0) from the demonstrations' first states. When the
skill is reproduced from a new start position, :func:`shifted_start_mean` moves the position
part of the mean to the requested start and keeps the learned initial velocity.
"""
from __future__ import annotations

import gtsam
import numpy as np

from .evaluation import (ResidualFamily, Residuals, TrajectoryEvaluator, WorkspaceStates,
                         custom_factors, gaussian_noise)


def workspace_start_residuals(states: WorkspaceStates, mean: np.ndarray,
                              index: int = 0) -> Residuals:
    """Residual (1, 6) = x(theta_index) - mean, Jacobian (1, 6, 2n)."""
    error = (states.x[index] - mean)[None]
    if states.jacobian is None:
        return Residuals(error, None)
    return Residuals(error, (states.jacobian[index][None],))


def shifted_start_mean(mean0: np.ndarray, start_position: np.ndarray) -> np.ndarray:
    """Learned initial mean (6,) with its position replaced by ``start_position`` (3,) [m]."""
    mean = np.array(mean0, dtype=float, copy=True)
    mean[:3] = start_position
    return mean


class WorkspaceStartFamily(ResidualFamily):
    """The single workspace start factor of a graph."""

    name = "workspace_start"

    def __init__(self, mean: np.ndarray, index: int = 0):
        self.mean = np.asarray(mean, dtype=float)
        self.index = int(index)

    def compute(self, evaluator: TrajectoryEvaluator, jacobians: bool) -> Residuals:
        return workspace_start_residuals(evaluator.workspace(jacobians), self.mean, self.index)


def workspace_start_factor(evaluator: TrajectoryEvaluator, mean: np.ndarray,
                           cov: np.ndarray, index: int = 0) -> gtsam.CustomFactor:
    """x(theta_index) ~ N(mean (6,), cov (6, 6))."""
    family = WorkspaceStartFamily(mean, index)
    return custom_factors(evaluator, family, [(index,)], [gaussian_noise(cov)])[0]
