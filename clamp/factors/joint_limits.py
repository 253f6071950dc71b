"""Joint-limit factor: hinges on joint positions and velocities of one support state.

e = [max(0, lo + m - q) + max(0, q - (hi - m)),  max(0, |qdot| - (vmax - mv))]  (2n,)
with margins m, mv; infinite limits (continuous joints) give zero rows.
"""
from __future__ import annotations

from collections.abc import Sequence

import gtsam
import numpy as np

from .evaluation import ResidualFamily, Residuals, TrajectoryEvaluator, custom_factors


def joint_limit_residuals(theta: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                          velocity_limits: np.ndarray, margin: float = 0.0,
                          velocity_margin: float = 0.0) -> Residuals:
    """Hinge residuals (T, 2n) for joint states theta (T, 2n); Jacobians (T, 2n, 2n) (diagonal)."""
    n = theta.shape[1] // 2
    q, qdot = theta[:, :n], theta[:, n:]
    below = (lower + margin) - q
    above = q - (upper - margin)
    over = np.abs(qdot) - (velocity_limits - velocity_margin)
    error = np.concatenate([np.maximum(below, 0.0) + np.maximum(above, 0.0),
                            np.maximum(over, 0.0)], axis=1)
    diag = np.concatenate([np.where(below > 0, -1.0, 0.0) + np.where(above > 0, 1.0, 0.0),
                           np.where(over > 0, np.sign(qdot), 0.0)], axis=1)
    T = theta.shape[0]
    jac = np.zeros((T, 2 * n, 2 * n))
    jac[:, np.arange(2 * n), np.arange(2 * n)] = diag
    return Residuals(error, (jac,))


class JointLimitFamily(ResidualFamily):
    """Joint position and velocity limit hinges at the given support states."""

    name = "joint_limits"
    cost = 0

    def __init__(self, indices: Sequence[int], lower: np.ndarray, upper: np.ndarray,
                 velocity_limits: np.ndarray, margin: float, velocity_margin: float):
        self.indices = np.asarray(indices, dtype=int)
        self.args = (np.asarray(lower, float), np.asarray(upper, float),
                     np.asarray(velocity_limits, float), float(margin), float(velocity_margin))

    def compute(self, evaluator: TrajectoryEvaluator, jacobians: bool) -> Residuals:
        return joint_limit_residuals(evaluator.theta[self.indices], *self.args)


def joint_limit_factors(evaluator: TrajectoryEvaluator, indices: Sequence[int], lower: np.ndarray,
                        upper: np.ndarray, velocity_limits: np.ndarray, sigma: float,
                        margin: float = 0.0, velocity_margin: float = 0.0) -> list[gtsam.CustomFactor]:
    """One factor per support state in ``indices``, isotropic noise ``sigma``."""
    family = JointLimitFamily(indices, lower, upper, velocity_limits, margin, velocity_margin)
    noise = gtsam.noiseModel.Isotropic.Sigma(2 * len(lower), float(sigma))
    return custom_factors(evaluator, family, [(int(i),) for i in indices], [noise] * len(indices))
