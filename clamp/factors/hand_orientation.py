"""The hand's orientation state of a support state, as the pose prior's chain reads it
(:mod:`clamp.prior.orientation_prior`): y = [log(Rbar^T R(q)), Rbar^T W(q) qdot] (6,) [rad,
rad/s] at the step's mean rotation Rbar, with its Jacobian

    d y / d theta = [[Jr^-1(r) R^T W, 0], [Rbar^T d omega / d q, Rbar^T W]]

(R the hand's rotation, W its angular Jacobian, omega = W qdot, Jr^-1 the inverse right
Jacobian of the log map, :func:`clamp.prior.so3.right_jacobian_inverse`): the one definition
the orientation chain's families (the transition and the start) share.

:func:`chain_states` computes it once per window of states for every state of a chain: the
chain's transition family, the solver's correction onto the chain's coordinates and the error
at a trial point read the same numbers (the window keeps them)."""
from __future__ import annotations

import numpy as np

from clamp.prior import so3

from .states import StateWindow

__all__ = ["orientation_state", "chain_states"]


def _values(R: np.ndarray, omega: np.ndarray, Rbar_T: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """y (K, 6) and its rotation part r (K, 3) of rotations R (K, 3, 3) and angular velocities
    omega (K, 3) at the transposed mean rotations Rbar_T (K, 3, 3)."""
    r = so3.log_map(Rbar_T @ R)
    return np.concatenate([r, np.einsum("kij,kj->ki", Rbar_T, omega)], axis=1), r


def _jacobian(r: np.ndarray, R: np.ndarray, W: np.ndarray, Rbar_T: np.ndarray,
              domega: np.ndarray) -> np.ndarray:
    """d y / d theta (K, 6, 2n) at r (K, 3), R (K, 3, 3), W and d omega / d q (K, 3, n)."""
    n = W.shape[-1]
    dy = np.zeros((len(r), 6, 2 * n))
    dy[:, :3, :n] = so3.right_jacobian_inverse(r) @ np.swapaxes(R, -1, -2) @ W
    dy[:, 3:, :n] = Rbar_T @ domega
    dy[:, 3:, n:] = Rbar_T @ W
    return dy


def orientation_state(window: StateWindow, rows: np.ndarray, mean_rotations: np.ndarray,
                      jacobians: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """y (K, 6) of the window rows ``rows`` (K,) at mean rotations (K, 3, 3), and d y / d theta
    (K, 6, 2n) of each row's own state (None unless ``jacobians``)."""
    R, W, omega, domega = window.rotation(jacobians)
    R, W = R[rows], W[rows]
    Rbar_T = np.swapaxes(mean_rotations, -1, -2)
    y, r = _values(R, omega[rows], Rbar_T)
    if not jacobians:
        return y, None
    return y, _jacobian(r, R, W, Rbar_T, domega[rows])


def chain_states(window: StateWindow, rotations: np.ndarray, jacobians: bool
                 ) -> tuple[np.ndarray, np.ndarray | None]:
    """The orientation states y (K, 6) of every window row at a chain's mean rotations
    ``rotations`` (T, 3, 3), indexed by support state (row k is support state window.first +
    k), and d y / d theta (K, 6, 2n) (None unless ``jacobians``): :func:`orientation_state` of
    every row, computed once per window and chain (the same ``rotations`` object), the
    Jacobian only when first asked for.

    The solver's correction (:mod:`clamp.optim.solver`) moves trial points onto the y its
    linear model predicts. The orientation families' residuals are linear in y, so a corrected
    trial point meets their predicted residuals exactly; a chart about the linearization
    point's own rotations meets them to first order only, which a chain this stiff refuses
    (docs/decisions.md#pose-prior)."""
    cache = window.chain_cache(rotations)
    if "y" not in cache:
        K = window.theta.shape[0]
        R, _, omega, _ = window.rotation(False)
        cache["Rbar_T"] = np.swapaxes(rotations[window.first:window.first + K], -1, -2)
        cache["y"], cache["r"] = _values(R, omega, cache["Rbar_T"])
    if not jacobians:
        return cache["y"], None
    if "dy" not in cache:
        R, W, _, domega = window.rotation(True)
        cache["dy"] = _jacobian(cache["r"], R, W, cache["Rbar_T"], domega)
    return cache["y"], cache["dy"]
