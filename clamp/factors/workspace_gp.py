"""Learned workspace GP factor on (theta_i, theta_{i+1}).

e_i = Phi_i x(theta_i) + u_i - x(theta_{i+1}),  x(theta) = [fk(q), J(q) qdot],  noise Q_i
(paper eq. 16). Jacobians: d e / d theta_i = Phi_i dx_i, d e / d theta_{i+1} = -dx_{i+1}.
"""
from __future__ import annotations

import gtsam
import numpy as np

from .evaluation import (ResidualFamily, Residuals, TrajectoryEvaluator, WorkspaceStates,
                         custom_factors, square_root_information)


def workspace_gp_residuals(states: WorkspaceStates, Phi: np.ndarray, u: np.ndarray) -> Residuals:
    """Residuals (T-1, 6) of all workspace GP factors, Jacobians (T-1, 6, 2n) w.r.t. theta_i, theta_{i+1}.

    states: workspace states of all T support states; Phi (T-1, 6, 6); u (T-1, 6).
    """
    x = states.x
    error = np.einsum("tij,tj->ti", Phi, x[:-1]) + u - x[1:]
    if states.jacobian is None:
        return Residuals(error, None)
    d_first = np.einsum("tij,tjk->tik", Phi, states.jacobian[:-1])
    d_second = -states.jacobian[1:]
    return Residuals(error, (d_first, d_second))


class WorkspaceGPFamily(ResidualFamily):
    """All T-1 learned workspace GP factors of a graph."""

    name = "workspace_gp"

    def __init__(self, Phi: np.ndarray, u: np.ndarray):
        self.Phi = np.asarray(Phi, dtype=float)
        self.u = np.asarray(u, dtype=float)

    def compute(self, evaluator: TrajectoryEvaluator, jacobians: bool) -> Residuals:
        return workspace_gp_residuals(evaluator.workspace(jacobians), self.Phi, self.u)


def workspace_gp_factors(evaluator: TrajectoryEvaluator, Phi: np.ndarray, u: np.ndarray,
                         Q: np.ndarray) -> list[gtsam.CustomFactor]:
    """One factor per step i -> i+1 (T-1 of them), noise Q_i (6, 6)."""
    family = WorkspaceGPFamily(Phi, u)
    steps = [(i, i + 1) for i in range(len(Phi))]
    R = square_root_information(np.asarray(Q, dtype=float))  # all steps in one batched call
    noise = [gtsam.noiseModel.Gaussian.SqrtInformation(r) for r in R]
    return custom_factors(evaluator, family, steps, noise)
