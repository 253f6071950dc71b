"""End-effector position targets (start, goal, via points): e_k = fk(q_{i_k}) - p_k (3,) [m].

d e / d theta_i = [J(q_i), 0].
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from clamp.validation import as_array, as_indices

from .family import Family, Linearization
from .states import StateWindow


class EEPositionFamily(Family):
    """One factor per target: state indices (K,), positions (K, 3) [m], sigmas (K,) [m]."""

    name = "ee_position"
    arity = 1
    kinematics = 1

    def __init__(self, indices: Sequence[int], targets: np.ndarray, sigmas: Sequence[float]):
        indices = as_indices(indices, "indices")
        order = np.argsort(indices, kind="stable")
        self.targets = as_array(targets, "targets", (len(order), 3))[order]
        sigmas = as_array(sigmas, "sigmas", (len(order),))
        super().__init__(indices[order], 3, sigma=sigmas[order])

    def residual(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Linearization:
        x, dx = window.workspace()
        i = window.local(self.first[rows])
        error = x[i, :3] - self.targets[rows]
        return Linearization(rows, error, dx[i, :3] if jacobians else None)
