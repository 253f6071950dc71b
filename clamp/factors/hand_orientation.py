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
    """The orientation states y (K, 6) of all window rows at the chain's mean rotations
    ``reference`` (K, 3, 3) and d y / d theta (K, 6, 2n): :func:`orientation_state` of every
    row. The solver's correction (:mod:`clamp.optim.solver`) moves trial points onto the y its
    linear model predicts. The orientation families' residuals are linear in y, so a corrected
    trial point meets their predicted residuals exactly; a chart about the linearization
    point's own rotations meets them to first order only, which a chain this stiff refuses
    (docs/decisions.md#pose-prior)."""
    return orientation_state(window, np.arange(window.q.shape[0]), reference, True)
