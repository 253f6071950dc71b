"""End-effector position targets (start, goal, via points): e_k = fk(q_{i_k}) - p_k (3,) [m].

d e / d theta_i = [J(q_i), 0].
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .family import Family, Linearization, targets_by_state
from .states import StateWindow


class EEPositionFamily(Family):
    """One factor per target: state indices (K,), positions (K, 3) [m], sigmas (K,) [m]."""

    name = "ee_position"
    arity = 1
    kinematics = 1

    def __init__(self, indices: Sequence[int], targets: np.ndarray, sigmas: Sequence[float]):
        indices, self.targets, sigmas = targets_by_state(indices, targets, sigmas, (3,))
        super().__init__(indices, 3, sigma=sigmas)

    def residual(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Linearization:
        x, dx = window.workspace()
        i = window.local(self.first[rows])
        error = x[i, :3] - self.targets[rows]
        return Linearization(rows, error, dx[i, :3] if jacobians else None)
