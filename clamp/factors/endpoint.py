"""Start, goal and via-point factors: joint configuration or end-effector position at a state.

Joint configuration: e = q_i - q_target (n,), linear (pure C++ factor).
End-effector position: e = fk(q_i) - p_target (3,), d e / d theta_i = [J(q_i), 0].
"""
from __future__ import annotations

from collections.abc import Sequence

import gtsam
import numpy as np

from clamp.keys import state_key

from .evaluation import (ResidualFamily, Residuals, TrajectoryEvaluator, WorkspaceStates,
                         custom_factors)
from .linear import linear_factor


def joint_position_factor(index: int, q_target: np.ndarray, sigma: float) -> gtsam.LinearContainerFactor:
    """q_index = q_target (n,) with isotropic noise ``sigma`` [rad]."""
    n = len(q_target)
    select = np.hstack([np.eye(n), np.zeros((n, n))])
    return linear_factor([state_key(index)], [select], q_target, np.eye(n) / sigma)


def ee_position_residuals(states: WorkspaceStates, indices: np.ndarray,
                          targets: np.ndarray) -> Residuals:
    """Residuals (K, 3) = p(theta_indices) - targets (K, 3), Jacobians (K, 3, 2n)."""
    error = states.x[indices, :3] - targets
    if states.jacobian is None:
        return Residuals(error, None)
    return Residuals(error, (states.jacobian[indices, :3, :],))


class EEPositionFamily(ResidualFamily):
    """End-effector position targets at given support states."""

    name = "ee_position"

    def __init__(self, indices: Sequence[int], targets: np.ndarray):
        self.indices = np.asarray(indices, dtype=int)
        self.targets = np.asarray(targets, dtype=float).reshape(-1, 3)

    def compute(self, evaluator: TrajectoryEvaluator, jacobians: bool) -> Residuals:
        return ee_position_residuals(evaluator.workspace(jacobians), self.indices, self.targets)


def ee_position_factors(evaluator: TrajectoryEvaluator, indices: Sequence[int],
                        targets: np.ndarray, sigmas: Sequence[float]) -> list[gtsam.CustomFactor]:
    """One factor per target: p(theta_indices[k]) = targets[k] (3,) [m], noise sigmas[k] [m]."""
    family = EEPositionFamily(indices, targets)
    noise = [gtsam.noiseModel.Isotropic.Sigma(3, float(s)) for s in sigmas]
    return custom_factors(evaluator, family, [(int(i),) for i in indices], noise)
