"""Learned orientation GP family: the pose prior's rotation chain through the arm, one factor
per step (theta_i, theta_{i+1}), i = 0 .. T-2.

e_i = y(theta_{i+1}) - Phi_i y(theta_i) - u_i (6,), y the hand's orientation state at the
step's mean rotation (:func:`clamp.factors.hand_orientation.chain_states`), noise Q_i:
the rotation counterpart of :mod:`clamp.factors.workspace_gp` (the residual is the prior's own
:func:`clamp.prior.linear_gaussian.transition_residuals`). Jacobians: d e / d theta_i =
-Phi_i dy_i, d e / d theta_{i+1} = dy_{i+1}.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from clamp.prior.linear_gaussian import transition_residuals
from clamp.validation import as_array

from .family import Family, Linearization, covariance_root
from .hand_orientation import chain_states
from .states import StateWindow


class OrientationGPFamily(Family):
    """rotations (T, 3, 3) the mean rotations of the steps; Phi (T-1, 6, 6), u (T-1, 6),
    Q (T-1, 6, 6) of a learned orientation chain (an OrientationPrior's)."""

    name = "orientation_gp"
    arity = 2
    kinematics = 1
    stiff_rotation = True

    def __init__(self, rotations: np.ndarray, Phi: np.ndarray, u: np.ndarray, Q: np.ndarray):
        self.Phi = as_array(Phi, "Phi", ("K", 6, 6))
        self.u = as_array(u, "u", (len(self.Phi), 6))
        self.rotations = as_array(rotations, "rotations", (len(self.Phi) + 1, 3, 3))
        super().__init__(np.arange(len(self.Phi)), 6,
                         sqrt_information=covariance_root(Q, "Q", (len(self.Phi), 6, 6)))

    @classmethod
    def of(cls, orientation: Any) -> "OrientationGPFamily":
        """The family of an OrientationPrior (``prior.orientation``)."""
        return cls(orientation.rotations, orientation.Phi, orientation.u, orientation.Q)

    def residual(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Linearization:
        before = window.local(self.first[rows])
        after = before + 1
        y, dy = chain_states(window, self.rotations, jacobians)     # every state of the window
        error = transition_residuals(self.Phi[rows], self.u[rows], y[before], y[after])
        if not jacobians:
            return Linearization(rows, error, None)
        return Linearization(rows, error, np.concatenate([-self.Phi[rows] @ dy[before],
                                                          dy[after]], axis=2))
