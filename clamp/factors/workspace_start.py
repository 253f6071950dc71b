"""Workspace start family: x(theta_0) against a Gaussian (mean (6,), covariance (6, 6)).

With the learned prior this is (mean0, cov0) from the demonstrations' first states. When the
skill is reproduced from a new start position, :func:`shifted_start_mean` moves the position
part of the mean to the requested start and keeps the learned initial velocity.
"""
from __future__ import annotations

import numpy as np

from clamp.validation import as_array, as_count

from .family import Family, Linearization, covariance_root
from .states import StateWindow


def shifted_start_mean(mean0: np.ndarray, start_position: np.ndarray) -> np.ndarray:
    """Learned initial mean (6,) with its position replaced by ``start_position`` (3,) [m]."""
    mean = np.array(mean0, dtype=float, copy=True)
    mean[:3] = start_position
    return mean


class WorkspaceStartFamily(Family):
    """One factor: e = x(theta_index) - mean (6,), noise cov (6, 6)."""

    name = "workspace_start"
    arity = 1
    kinematics = 1

    def __init__(self, mean: np.ndarray, cov: np.ndarray, index: int = 0):
        self.mean = as_array(mean, "mean", (6,)).reshape(1, 6)
        super().__init__([as_count(index, "index", minimum=0)], 6,
                         sqrt_information=covariance_root(cov, "cov", (6, 6))[None])

    def residual(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Linearization:
        x, dx = window.workspace()
        i = window.local(self.first[rows])
        error = x[i] - self.mean[rows]
        return Linearization(rows, error, dx[i] if jacobians else None)
