"""Joint-limit family: hinges on the joint positions and velocities of every support state.

e = [max(0, lo + m - q) + max(0, q - (hi - m)),  max(0, |qdot| - (vmax - mv))]  (2n,)
with margins m [rad], mv [rad/s]; infinite limits (continuous joints) give zero rows. Only
states with an active hinge are returned (the others are exactly zero).
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from clamp.errors import InvalidParameterError
from clamp.validation import as_array, as_scalar

from .family import Family, Linearization
from .states import StateWindow


class JointLimitFamily(Family):
    """One factor per support state in ``indices``, isotropic noise ``sigma``."""

    name = "joint_limits"
    arity = 1
    kinematics = 0
    role = "constraint"

    def __init__(self, indices: Sequence[int], lower: np.ndarray, upper: np.ndarray,
                 velocity_limits: np.ndarray, sigma: float, margin: float = 0.0,
                 velocity_margin: float = 0.0):
        lower = as_array(lower, "lower", ("n",), allow_infinite=True)
        upper = as_array(upper, "upper", (len(lower),), allow_infinite=True)
        velocity_limits = as_array(velocity_limits, "velocity_limits", (len(lower),),
                                   allow_infinite=True)
        if np.any(lower > upper):
            j = int(np.argmax(lower > upper))
            raise InvalidParameterError(f"lower: expected lower <= upper joint limits, got "
                                        f"lower[{j}] = {lower[j]} > upper[{j}] = {upper[j]} rad")
        if np.any(velocity_limits < 0):
            raise InvalidParameterError(f"velocity_limits: expected limits >= 0 rad/s, got "
                                        f"{float(velocity_limits.min())}")
        margin = as_scalar(margin, "margin", minimum=0.0)
        velocity_margin = as_scalar(velocity_margin, "velocity_margin", minimum=0.0)
        self.low = lower + margin
        self.high = upper - margin
        self.vmax = velocity_limits - velocity_margin
        super().__init__(indices, 2 * len(self.low), sigma=sigma)

    def residual(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Linearization:
        i = window.local(self.first[rows])
        q, qdot = window.q[i], window.qdot[i]
        n = q.shape[1]
        shift = np.broadcast_to(self.offset(rows), (len(rows), 2 * n))
        below = self.low - q + shift[:, :n]
        above = q - self.high + shift[:, :n]
        over = np.abs(qdot) - self.vmax + shift[:, n:]
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
