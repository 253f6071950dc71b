"""Workspace start family: x(theta_0) against a Gaussian (mean (6,), covariance (6, 6)).

With the learned prior this is (mean0, cov0) from the demonstrations' first states. When the
skill is reproduced from a new start position, :func:`shifted_start_mean` moves the position
part of the mean to the requested start and the velocity part to the velocity the learned
initial state expects there (the Gaussian conditioned on its position): with the position held
at the start, the factor's minimiser is then the learned prior conditioned on the start, as
:func:`clamp.condition_prior` gives it.
"""
from __future__ import annotations

import numpy as np

from clamp.prior.chain import start_response
from clamp.validation import as_array, as_count

from .family import Family, Linearization, covariance_root
from .states import StateWindow


def shifted_start_mean(mean0: np.ndarray, cov0: np.ndarray, start_position: np.ndarray
                       ) -> np.ndarray:
    """Learned initial state N(mean0 (6,), cov0 (6, 6)) conditioned on its position being
    ``start_position`` (3,) [m]: the mean (6,) [m, m/s] with that position and the velocity
    mean0[3:] + cov0[3:, :3] cov0[:3, :3]^-1 (start_position - mean0[:3])."""
    mean0 = np.asarray(mean0, dtype=float)
    start_position = np.asarray(start_position, dtype=float)
    velocity = start_response(np.asarray(cov0, dtype=float))[3:] @ (start_position - mean0[:3])
    return np.concatenate([start_position, mean0[3:] + velocity])


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
