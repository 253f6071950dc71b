"""Posture motion: the deviation from a reference trajectory (the free plan) is a
constant-velocity GP, one factor per step. Linear.

e_i = delta_{i+1} - Phi(dt) delta_i, delta_i = theta_i - theta_ref_i (2n,), with the joint GP's
Phi(dt) and Q(dt) for a power spectral density Qc [rad^2 / s^3] (:mod:`clamp.factors.joint_gp`).

The obstacle plan's second tie to the free plan (with :class:`~clamp.factors.PostureFamily`,
which holds each configuration near the free plan's): the reference's joint GP (Qc 1) lets a
joint's velocity change by ~0.4 rad/s per 0.16 s step at no cost, so around an obstacle the
arm swung its wrist out and back within a few states. Penalising the acceleration of the
deviation, not of the motion itself, keeps the free plan as it is (its own accelerations cost
nothing here) and makes the detour smooth and short (measurements:
docs/decisions.md#posture_qc).
"""
from __future__ import annotations

import numpy as np

from clamp.errors import ShapeError
from clamp.validation import as_array

from .family import Linearization
from .joint_gp import JointGPFamily
from .states import StateWindow


class PostureMotionFamily(JointGPFamily):
    """T - 1 factors between consecutive states of the reference joint states (T, 2n) of step
    dt [s]: the joint GP of power spectral density Qc [rad^2 / s^3] on theta - reference."""

    name = "posture_motion"

    def __init__(self, reference: np.ndarray, dt: float, Qc: float):
        reference = as_array(reference, "reference", (None, None))
        T, d = reference.shape
        if T < 2 or d % 2:
            raise ShapeError(f"reference: expected joint states (T >= 2, 2n), got shape "
                             f"{reference.shape}")
        super().__init__(T, d // 2, dt, Qc)
        #: the reference's own GP residuals (T - 1, 2n), subtracted: the reference costs nothing
        self.reference_residual = reference[1:] - reference[:-1] @ self.Phi.T

    def residual(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Linearization:
        lin = super().residual(window, rows, jacobians)
        return Linearization(lin.rows, lin.error - self.reference_residual[self.first[rows]],
                             lin.jacobian)
