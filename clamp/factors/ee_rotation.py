"""End-effector rotation targets (goal and via poses): e_k = log(R_k^T R(q_{i_k})) (3,) [rad].

d e / d theta_i = [Jr^-1(e) R(q_i)^T W(q_i), 0] (W the hand's angular Jacobian, Jr^-1 the
inverse right Jacobian of the log map, :func:`clamp.prior.so3.right_jacobian_inverse`).
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from clamp.prior import so3

from .family import Family, Linearization, targets_by_state
from .states import StateWindow


class EERotationFamily(Family):
    """One factor per target: state indices (K,), rotations (K, 3, 3), sigmas (K,) [rad]."""

    name = "ee_rotation"
    arity = 1
    kinematics = 1

    def __init__(self, indices: Sequence[int], targets: np.ndarray, sigmas: Sequence[float]):
        indices, self.targets, sigmas = targets_by_state(indices, targets, sigmas, (3, 3))
        super().__init__(indices, 3, sigma=sigmas)

    def residual(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Linearization:
        R, W, _, _ = window.rotation(False)
        i = window.local(self.first[rows])
        error = so3.log_map(np.swapaxes(self.targets[rows], -1, -2) @ R[i])
        if not jacobians:
            return Linearization(rows, error, None)
        n = window.n
        jac = np.zeros((len(rows), 3, 2 * n))
        jac[:, :, :n] = so3.right_jacobian_inverse(error) @ np.swapaxes(R[i], -1, -2) @ W[i]
        return Linearization(rows, error, jac)
