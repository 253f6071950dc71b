"""Obstacle factor: one per support state, all collision spheres in one residual vector.

e_s = max(0, eps + r_s - sdf(c_s)) for sphere s (centre c_s, radius r_s), noise sigma_obs;
d e_s / d q = -grad sdf(c_s)^T d c_s / d q where the hinge is active, 0 otherwise; 0 for qdot.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence

import gtsam
import numpy as np

from .evaluation import ResidualFamily, Residuals, TrajectoryEvaluator, custom_factors

DistanceQuery = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


def obstacle_residuals(centres: np.ndarray, centre_jacobians: np.ndarray | None,
                       radii: np.ndarray, query: DistanceQuery, epsilon: float) -> Residuals:
    """Hinge residuals (T, S) for sphere centres (T, S, 3), Jacobians (T, S, 2n) w.r.t. theta.

    centre_jacobians (T, S, 3, n) or None; radii (S,); query(points (..., 3)) returns the
    signed distance (...) and its gradient (..., 3).
    """
    distance, gradient = query(centres)
    hinge = epsilon + radii - distance
    active = hinge > 0.0
    error = np.where(active, hinge, 0.0)
    if centre_jacobians is None:
        return Residuals(error, None)
    T, S, _, n = centre_jacobians.shape
    jac = np.zeros((T, S, 2 * n))
    jac[:, :, :n] = -np.einsum("tsk,tskj->tsj", gradient * active[..., None], centre_jacobians)
    return Residuals(error, (jac,))


class ObstacleFamily(ResidualFamily):
    """Obstacle hinge of every collision sphere at the given support states."""

    name = "obstacle"
    cost = 2

    def __init__(self, indices: Sequence[int], radii: np.ndarray, query: DistanceQuery,
                 epsilon: float):
        self.indices = np.asarray(indices, dtype=int)
        self.radii = np.asarray(radii, dtype=float)
        self.query = query
        self.epsilon = float(epsilon)

    def compute(self, evaluator: TrajectoryEvaluator, jacobians: bool) -> Residuals:
        centres, centre_jac = evaluator.spheres(jacobians)
        rows = self.indices
        sub_jac = None if centre_jac is None else centre_jac[rows]
        return obstacle_residuals(centres[rows], sub_jac, self.radii, self.query, self.epsilon)


def obstacle_factors(evaluator: TrajectoryEvaluator, indices: Sequence[int], radii: np.ndarray,
                     query: DistanceQuery, epsilon: float,
                     sigma: float) -> list[gtsam.CustomFactor]:
    """One factor per support state in ``indices``; ``query`` is e.g. SignedDistanceField.query."""
    family = ObstacleFamily(indices, radii, query, epsilon)
    noise = gtsam.noiseModel.Isotropic.Sigma(len(radii), float(sigma))
    return custom_factors(evaluator, family, [(int(i),) for i in indices], [noise] * len(indices))
