"""Constant-velocity joint-space GP prior factor on (theta_i, theta_{i+1}) (as in GPMP2).

e_i = Phi(dt) theta_i - theta_{i+1},  Phi(dt) = [[I, dt I], [0, I]],
Q(dt) = Qc kron [[dt^3/3, dt^2/2], [dt^2/2, dt]] (paper eq. 17). The factor is linear, so it
is carried by a pure C++ linear factor.
"""
from __future__ import annotations

import gtsam
import numpy as np

from clamp.keys import state_key

from .evaluation import Residuals, square_root_information
from .linear import linear_factor


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


def joint_gp_residuals(theta: np.ndarray, dt: float) -> Residuals:
    """Residuals (T-1, 2n) of all joint GP factors for joint states theta (T, 2n), with Jacobians."""
    T, d = theta.shape
    Phi = joint_gp_transition(d // 2, dt)
    error = theta[:-1] @ Phi.T - theta[1:]
    return Residuals(error, (np.broadcast_to(Phi, (T - 1, d, d)),
                             np.broadcast_to(-np.eye(d), (T - 1, d, d))))


def joint_gp_factors(num_states: int, n: int, dt: float,
                     Qc: float | np.ndarray = 1.0) -> list[gtsam.LinearContainerFactor]:
    """The T-1 joint GP factors between consecutive support states of step ``dt`` [s]."""
    Phi = joint_gp_transition(n, dt)
    Q = joint_gp_covariance(n, dt, Qc)
    R = square_root_information(Q)
    minus_eye = -np.eye(2 * n)
    zero = np.zeros(2 * n)
    return [linear_factor([state_key(i), state_key(i + 1)], [Phi, minus_eye], zero, R)
            for i in range(num_states - 1)]
