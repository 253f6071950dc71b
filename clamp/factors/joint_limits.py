"""Joint-limit family: hinges on the joint positions and velocities of every support state.

e = [max(0, lo + m - q) + max(0, q - (hi - m)),  max(0, |qdot| - (vmax - mv))]  (2n,)
with margins m [rad], mv [rad/s]; infinite limits (continuous joints) give zero rows. Only
states with an active hinge are returned (the others are exactly zero).
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .family import Family, Linearization
from .states import StateWindow


class JointLimitFamily(Family):
    """One factor per support state in ``indices``, isotropic noise ``sigma``."""

    name = "joint_limits"
    arity = 1
    cost = 0

    def __init__(self, indices: Sequence[int], lower: np.ndarray, upper: np.ndarray,
                 velocity_limits: np.ndarray, sigma: float, margin: float = 0.0,
                 velocity_margin: float = 0.0):
        self.low = np.asarray(lower, dtype=float) + margin
        self.high = np.asarray(upper, dtype=float) - margin
        self.vmax = np.asarray(velocity_limits, dtype=float) - velocity_margin
        super().__init__(indices, 2 * len(self.low), sigma=sigma)

    def residual(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Linearization:
        i = window.local(self.first[rows])
        q, qdot = window.q[i], window.qdot[i]
        below = self.low - q
        above = q - self.high
        over = np.abs(qdot) - self.vmax
        slope = np.concatenate([np.where(below > 0, -1.0, 0.0) + np.where(above > 0, 1.0, 0.0),
                                np.where(over > 0, np.sign(qdot), 0.0)], axis=1)
        active = np.any(slope != 0.0, axis=1)
        error = np.concatenate([np.maximum(below, 0.0) + np.maximum(above, 0.0),
                                np.maximum(over, 0.0)], axis=1)[active]
        if not jacobians:
            return Linearization(rows[active], error, None)
        d = slope.shape[1]
        jac = np.zeros((int(active.sum()), d, d))
        jac[:, np.arange(d), np.arange(d)] = slope[active]
        return Linearization(rows[active], error, jac)
