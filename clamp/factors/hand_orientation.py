"""The hand's orientation state of a support state, as the pose prior's chain reads it
(:mod:`clamp.prior.orientation_prior`): y = [log(Rbar^T R(q)), Rbar^T W(q) qdot] (6,) [rad,
rad/s] at the step's mean rotation Rbar, with its Jacobian

    d y / d theta = [[Jr^-1(r) R^T W, 0], [Rbar^T d omega / d q, Rbar^T W]]

(R the hand's rotation, W its angular Jacobian, omega = W qdot, Jr^-1 the inverse right
Jacobian of the log map, :func:`clamp.prior.so3.right_jacobian_inverse`): the one definition
the orientation chain's families (the transition and the start) share."""
from __future__ import annotations

import numpy as np

from clamp.prior import so3

from .states import StateWindow

__all__ = ["orientation_state", "rotation_chart"]


def orientation_state(window: StateWindow, rows: np.ndarray, mean_rotations: np.ndarray,
                      jacobians: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """y (K, 6) of the window rows ``rows`` (K,) at mean rotations (K, 3, 3), and d y / d theta
    (K, 6, 2n) of each row's own state (None unless ``jacobians``)."""
    R, W, omega, domega = window.rotation(jacobians)
    R, W = R[rows], W[rows]
    Rbar_T = np.swapaxes(mean_rotations, -1, -2)
    r = so3.log_map(Rbar_T @ R)
    y = np.concatenate([r, np.einsum("kij,kj->ki", Rbar_T, omega[rows])], axis=1)
    if not jacobians:
        return y, None
    n = window.n
    dy = np.zeros((len(rows), 6, 2 * n))
    dy[:, :3, :n] = so3.right_jacobian_inverse(r) @ np.swapaxes(R, -1, -2) @ W
    dy[:, 3:, :n] = Rbar_T @ domega[rows]
    dy[:, 3:, n:] = Rbar_T @ W
    return y, dy


def rotation_chart(window: StateWindow, reference: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The hand's rotation and angular velocity in a chart about ``reference`` rotations
    (K, 3, 3) of all window rows: z (K, 6) = [log(reference^T R), omega] [rad, rad/s] and
    d z / d theta (K, 6, 2n). An orientation state y is, near the reference, a function of z
    alone (its angular velocity exactly linear in z's, its rotation to first order), so a
    trial point on the predicted z is on the predicted y to that order: the solver's
    correction (:mod:`clamp.optim.solver`) moves trial points onto it. The rotation rows of
    d z / d q are the chord R^T W (exact at the reference, where the log map's right Jacobian
    is I; a Gauss-Newton update towards a target a step away needs no more)."""
    R, W, omega, domega = window.rotation()
    r = so3.log_map(np.swapaxes(reference, -1, -2) @ R)
    n = window.n
    dz = np.zeros((len(R), 6, 2 * n))
    dz[:, :3, :n] = np.swapaxes(R, -1, -2) @ W          # the chord: exact at r = 0
    dz[:, 3:, :n] = domega
    dz[:, 3:, n:] = W
    return np.concatenate([r, omega], axis=1), dz
