"""Learned workspace GP family: one factor per step (theta_i, theta_{i+1}), i = 0 .. T-2.

e_i = x(theta_{i+1}) - Phi_i x(theta_i) - u_i, x(theta) = [fk(q), J(q) qdot], noise Q_i (paper
eq. 16; the residual is the prior's own :func:`clamp.prior.linear_gaussian.transition_residuals`).
Jacobians: d e / d theta_i = -Phi_i dx_i, d e / d theta_{i+1} = dx_{i+1}.
"""
from __future__ import annotations

import numpy as np

from clamp.prior.linear_gaussian import transition_residuals
from clamp.validation import as_array

from .family import Family, Linearization, covariance_root
from .states import StateWindow


class WorkspaceGPFamily(Family):
    """Phi (T-1, 6, 6), u (T-1, 6), Q (T-1, 6, 6) of a learned workspace prior."""

    name = "workspace_gp"
    arity = 2
    kinematics = 1

    def __init__(self, Phi: np.ndarray, u: np.ndarray, Q: np.ndarray):
        self.Phi = as_array(Phi, "Phi", ("K", 6, 6))
        self.u = as_array(u, "u", (len(self.Phi), 6))
        super().__init__(np.arange(len(self.Phi)), 6,
                         sqrt_information=covariance_root(Q, "Q", (len(self.Phi), 6, 6)))

    def residual(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Linearization:
        x, dx = window.workspace()
        i = window.local(self.first[rows])
        error = transition_residuals(self.Phi[rows], self.u[rows], x[i], x[i + 1])
        if not jacobians:
            return Linearization(rows, error, None)
        jac = np.concatenate([-self.Phi[rows] @ dx[i], dx[i + 1]], axis=2)
        return Linearization(rows, error, jac)
