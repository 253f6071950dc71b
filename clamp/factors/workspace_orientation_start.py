"""Orientation start family: the hand's orientation state y(theta_0) (rotation in the tangent
space of the first mean rotation, angular velocity) against a Gaussian (mean (6,), covariance
(6, 6)), the rotation counterpart of :mod:`clamp.factors.workspace_start`. The planner gives
it the learned initial state conditioned on the arm's own start rotation
(:func:`clamp.factors.shifted_start_mean`): the start pose is the arm's, and the factor asks
for the angular velocity the demonstrations start with from there."""
from __future__ import annotations

import numpy as np

from clamp.validation import as_array, as_count

from .family import Family, Linearization, covariance_root
from .hand_orientation import orientation_state
from .states import StateWindow


class OrientationStartFamily(Family):
    """One factor: e = y(theta_index) - mean (6,) at the mean rotation ``rotation`` (3, 3) of
    that step, noise cov (6, 6)."""

    name = "orientation_start"
    arity = 1
    kinematics = 1

    def __init__(self, rotation: np.ndarray, mean: np.ndarray, cov: np.ndarray, index: int = 0):
        self.rotation = as_array(rotation, "rotation", (3, 3)).reshape(1, 3, 3)
        self.mean = as_array(mean, "mean", (6,)).reshape(1, 6)
        super().__init__([as_count(index, "index", minimum=0)], 6,
                         sqrt_information=covariance_root(cov, "cov", (6, 6))[None])

    def residual(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Linearization:
        i = window.local(self.first[rows])
        y, dy = orientation_state(window, i, self.rotation[rows], jacobians)
        return Linearization(rows, y - self.mean[rows], dy)
