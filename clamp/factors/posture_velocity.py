"""Posture velocity: every state's joint velocity held near a reference trajectory's (the free
plan's), e_i = qdot_i - qdot_ref_i (n,), noise sigma [rad/s] per joint. Linear.

The obstacle plan's third tie to the free plan (with :class:`~clamp.factors.PostureFamily` and
:class:`~clamp.factors.PostureMotionFamily`). The motion tie penalises the deviation's
acceleration, so a deviation that keeps a constant velocity costs nothing: once an obstacle
set a joint moving (the Jaco's last joint, which does not move the end-effector point), it
kept turning to the end of the plan (6 rad of wrist spin) wherever the posture tie was loose
or absent (the untied restarts). Summed over the states this is the squared excess joint
speed, the quantity behind the joint path's excess over the free plan (measurements:
docs/decisions.md#posture_velocity_sigma).
"""
from __future__ import annotations

import numpy as np

from clamp.errors import ShapeError
from clamp.validation import as_array, as_scalar

from .joint_target import JointTargetFamily


class PostureVelocityFamily(JointTargetFamily):
    """One factor per state of the reference joint states (T, 2n): its velocity within sigma
    [rad/s]."""

    name = "posture_velocity"
    velocities = True

    def __init__(self, reference: np.ndarray, sigma: float):
        reference = as_array(reference, "reference", (None, None))
        T, d = reference.shape
        if d % 2:
            raise ShapeError(f"reference: expected joint states (T, 2n), got shape "
                             f"{reference.shape}")
        sigma = as_scalar(sigma, "sigma", strictly_positive=True)
        super().__init__(np.arange(T), reference[:, d // 2:], np.full(T, sigma))
