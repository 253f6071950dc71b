"""Joint-limit family: hinges on the joint positions and velocities of every support state.

e = [max(0, max(lo + m - q, q - (hi - m))),  max(0, |qdot| - (vmax - mv))]  (2n,)
with margins m [rad], mv [rad/s] (the nearer limit's hinge: the two sides of a joint cannot both
be out); infinite limits (continuous joints) give zero rows. Only states with an active hinge
are returned (the others are exactly zero; hinge and shift are the base class's).
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from clamp.errors import InvalidParameterError
from clamp.validation import as_array, as_scalar

from .family import Constraint, Family
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

    def constraint(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Constraint:
        i = window.local(self.first[rows])
        q, qdot = window.q[i], window.qdot[i]
        below, above = self.low - q, q - self.high
        value = np.concatenate([np.maximum(below, above), np.abs(qdot) - self.vmax], axis=1)

        def jacobian(states: np.ndarray, active: np.ndarray) -> np.ndarray:
            side = np.where(below[states] > above[states], -1.0, 1.0)
            slope = np.where(active, np.concatenate([side, np.sign(qdot[states])], axis=1), 0.0)
            d = slope.shape[1]
            jac = np.zeros((len(states), d, d))
            jac[:, np.arange(d), np.arange(d)] = slope
            return jac
        return Constraint(value, jacobian if jacobians else None)
