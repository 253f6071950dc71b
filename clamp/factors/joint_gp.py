"""Constant-velocity joint-space GP prior family (as in GPMP2), one factor per step.

e_i = theta_{i+1} - Phi(dt) theta_i,  Phi(dt) = [[I, dt I], [0, I]],
Q(dt) = Qc kron [[dt^3/3, dt^2/2], [dt^2/2, dt]] (paper eq. 17). Linear in theta.
"""
from __future__ import annotations

import numpy as np

from clamp.validation import as_count, as_covariance, as_scalar

from .family import Family, Linearization, square_root_information
from .states import StateWindow


def joint_gp_transition(n: int, dt: float) -> np.ndarray:
    """Phi(dt) (2n, 2n) of the constant-velocity model."""
    eye = np.eye(n)
    return np.block([[eye, dt * eye], [np.zeros((n, n)), eye]])


def joint_gp_covariance(n: int, dt: float, Qc: float | np.ndarray = 1.0) -> np.ndarray:
    """Q(dt) (2n, 2n) = Qc kron [[dt^3/3, dt^2/2], [dt^2/2, dt]]; Qc scalar or (n, n)."""
    Qc = np.atleast_2d(np.asarray(Qc, dtype=float))
    if Qc.shape == (1, 1):
        Qc = Qc[0, 0] * np.eye(n)
    block = np.array([[dt ** 3 / 3.0, dt ** 2 / 2.0], [dt ** 2 / 2.0, dt]])
    return np.kron(block, Qc)


class JointGPFamily(Family):
    """T-1 factors between consecutive support states of step ``dt`` [s] for n joints."""

    name = "joint_gp"
    arity = 2
    kinematics = 0
    linear = True

    def __init__(self, num_states: int, n: int, dt: float, Qc: float | np.ndarray = 1.0):
        num_states = as_count(num_states, "num_states", minimum=2)
        n = as_count(n, "n")
        dt = as_scalar(dt, "dt", strictly_positive=True)
        Qc = as_scalar(Qc, "Qc", strictly_positive=True) if np.ndim(Qc) == 0 \
            else as_covariance(Qc, "Qc", (n, n))
        self.Phi = joint_gp_transition(n, dt)
        R = square_root_information(joint_gp_covariance(n, dt, Qc))
        super().__init__(np.arange(num_states - 1), 2 * n,
                         sqrt_information=np.broadcast_to(R, (num_states - 1, 2 * n, 2 * n)))
        self._jacobian = np.concatenate([-self.Phi, np.eye(2 * n)], axis=1)

    def residual(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Linearization:
        i = window.local(self.first[rows])
        theta = window.theta
        error = theta[i + 1] - theta[i] @ self.Phi.T
        jac = np.broadcast_to(self._jacobian, (len(rows),) + self._jacobian.shape) \
            if jacobians else None
        return Linearization(rows, error, jac)
