"""Learning a trajectory prior from demonstrations (CLAMP paper, section 4.3, eq. 11-13).

For every step i -> i+1 the next state of the M demonstrations is regressed on ``[1, x_i]``
by ridge regression (penalty ``ridge * ||Phi_i||_F^2``, the bias column not penalised):

    Phi_i, u_i = argmin sum_m ||x^m_{i+1} - Phi_i x^m_i - u_i||^2 + ridge ||Phi_i||_F^2
    Q_i = 1/M sum_m r^m_i r^m_i^T + jitter I,     r^m_i = x^m_{i+1} - Phi_i x^m_i - u_i

(eq. 13 normalises by M; the reference MATLAB code divides by M - 1). Because the bias is
free, u_i = mean(x_{i+1}) - Phi_i mean(x_i) and the prior's mean reproduces the
demonstrations' mean at every step for any ridge.

By default every axis d is regressed separately on its own state ``[p_d, v_d]`` (2 unknowns
plus the bias per output, well posed from M = 3 demonstrations): Phi_i, Q_i and the initial
covariance are then block-diagonal over the axes, in the ``[p (A), v (A)]`` state ordering.
``coupled=True`` regresses the full D = 2A state on itself (needs M > D without ridge).
All T - 1 regressions are solved at once with batched SVDs.

The same learner gives the workspace prior (A = 3 Cartesian axes, :func:`learn_prior`) and a
configuration-space prior (A = n joints, :func:`learn_joint_prior`, paper section 4.2).
"""
from __future__ import annotations

import warnings
from typing import cast

import numpy as np

from clamp.errors import (ClampWarning, DegenerateDemonstrationsError,
                          InsufficientDemonstrationsError, InvalidParameterError, ShapeError)
from clamp.prior import LinearGaussianPrior, WorkspacePrior
from clamp.validation import as_array, as_bool, as_scalar, as_time
from scenes.validation import MAX_COORDINATE

#: Smallest spread (largest standard deviation over the state's coordinates, across the
#: demonstrations; m, m/s or rad, rad/s) accepted at every step. Identical demonstrations have 0
#: and would give a prior of zero variance (Q = jitter); the real recordings in
#: shared/datasets spread by 3 mm or more at every step.
MIN_SPREAD = 1e-6

__all__ = ["learn_prior", "learn_joint_prior", "fit_transitions", "state_groups"]


def state_groups(num_axes: int, coupled: bool) -> np.ndarray:
    """Index groups (G, k) into the state ``[positions (A), velocities (A)]`` regressed jointly.

    Per axis: G = A groups ``[d, A + d]``; coupled: one group with all D = 2A indices.
    """
    if coupled:
        return np.arange(2 * num_axes)[None, :]
    axes = np.arange(num_axes)
    return np.stack([axes, axes + num_axes], axis=1)


def _scatter_blocks(blocks: np.ndarray, groups: np.ndarray, size: int) -> np.ndarray:
    """Place per-group blocks (..., G, k, k) into block-structured matrices (..., D, D)."""
    out = np.zeros(blocks.shape[:-3] + (size, size))
    out[..., groups[:, :, None], groups[:, None, :]] = blocks
    return out


def _ridge_fit(X: np.ndarray, Y: np.ndarray, ridge: float) -> np.ndarray:
    """Ridge coefficients B (..., k, k_out) minimising ||Y - X B||^2 + ridge ||B||^2.

    X (..., M, k), Y (..., M, k_out) are centred. Solved through the SVD of X, which stays
    accurate when X is rank deficient; ridge = 0 gives the minimum-norm least-squares fit.
    """
    U, s, Vt = np.linalg.svd(X, full_matrices=False)
    if ridge > 0:
        gain = s / (s * s + ridge)
    else:
        cutoff = max(X.shape[-2:]) * np.finfo(float).eps * s[..., :1]
        gain = np.divide(1.0, s, out=np.zeros_like(s), where=s > cutoff)
    UtY = np.swapaxes(U, -1, -2) @ Y
    return np.swapaxes(Vt, -1, -2) @ (gain[..., None] * UtY)


def fit_transitions(states: np.ndarray, groups: np.ndarray, ridge: float,
                    jitter: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-step ridge regression of x_{i+1} on [1, x_i] over M demonstrations.

    states (M, T, D); groups (G, k) index groups regressed jointly (see :func:`state_groups`).
    Returns Phi (T-1, D, D), u (T-1, D), Q (T-1, D, D) with ``jitter`` on Q's diagonal.
    """
    M, _, D = states.shape
    # (T-1, G, M, k): one small regression per step and group, all solved in one batch.
    X = np.moveaxis(states[:, :-1][:, :, groups], 0, 2)
    Y = np.moveaxis(states[:, 1:][:, :, groups], 0, 2)
    x_bar = X.mean(axis=2, keepdims=True)
    y_bar = Y.mean(axis=2, keepdims=True)
    Xc, Yc = X - x_bar, Y - y_bar
    B = _ridge_fit(Xc, Yc, ridge)                      # (T-1, G, k, k): Phi_g^T
    Phi_g = np.swapaxes(B, -1, -2)
    u_g = (y_bar - x_bar @ B)[..., 0, :]               # (T-1, G, k)
    R = Yc - Xc @ B
    Q_g = np.swapaxes(R, -1, -2) @ R / M
    Phi = _scatter_blocks(Phi_g, groups, D)
    Q = _scatter_blocks(Q_g, groups, D) + jitter * np.eye(D)
    Q = 0.5 * (Q + np.swapaxes(Q, -1, -2))
    u = np.zeros((states.shape[1] - 1, D))
    u[:, groups] = u_g
    return Phi, u, Q


def _initial_state(states: np.ndarray, groups: np.ndarray,
                   jitter: float) -> tuple[np.ndarray, np.ndarray]:
    """Mean (D,) and biased (1/M) covariance (D, D) of the first states, block-diagonal by group."""
    x0 = states[:, 0]
    mean0 = x0.mean(axis=0)
    centred = x0 - mean0
    full = centred.T @ centred / x0.shape[0]
    mask = _scatter_blocks(np.ones((groups.shape[0],) + (groups.shape[1],) * 2), groups,
                           x0.shape[1]).astype(bool)
    cov0 = np.where(mask, full, 0.0) + jitter * np.eye(x0.shape[1])
    return mean0, cov0


def _learn(states: np.ndarray, time: np.ndarray, *, coupled: bool, ridge: float, jitter: float,
           prior_class: type[LinearGaussianPrior], kind: str,
           state_names: tuple[str, ...] | None) -> LinearGaussianPrior:
    """Shared learner: states (M, T, D = 2A) ordered [positions, velocities] -> prior."""
    ridge = as_scalar(ridge, "ridge", minimum=0.0)
    jitter = as_scalar(jitter, "jitter", minimum=0.0)
    coupled = as_bool(coupled, "coupled")
    M, T, D = states.shape
    if M < 2:
        raise InsufficientDemonstrationsError(
            f"demonstrations: expected at least 2 demonstrations, got {M}")
    if T < 2:
        raise ShapeError(f"demonstrations: expected at least 2 time steps, got {T}")
    check_spread(states)
    groups = state_groups(D // 2, coupled)
    unknowns = groups.shape[1] + 1                     # slopes of one output + bias
    if M < unknowns:
        what = f"coupled learning of D = {D}" if coupled else "per-axis learning"
        if ridge == 0:
            raise InsufficientDemonstrationsError(
                f"demonstrations: {what} needs at least {unknowns} demonstrations without "
                f"regularisation, got {M}; pass ridge > 0 or use more demonstrations")
        warnings.warn(f"{what} from {M} demonstrations is underdetermined ({unknowns} unknowns "
                      f"per output); the fit relies on ridge = {ridge:g} and Q has rank "
                      f"<= {M - 1} before jitter", ClampWarning, stacklevel=3)
    Phi, u, Q = fit_transitions(states, groups, ridge, jitter)
    mean0, cov0 = _initial_state(states, groups, jitter)
    info = {"coupled": bool(coupled), "ridge": ridge, "jitter": jitter, "num_demos": int(M)}
    return prior_class(time, Phi, u, Q, mean0, cov0, kind=kind, info=info,
                       state_names=state_names)


def check_spread(states: np.ndarray) -> None:
    """Refuse demonstrations (M, T, D) that coincide at some step (spread below MIN_SPREAD)."""
    spread = states.std(axis=0).max(axis=1)                    # (T,)
    step = int(np.argmin(spread))
    if spread[step] < MIN_SPREAD:
        flat = int(np.count_nonzero(spread < MIN_SPREAD))
        raise DegenerateDemonstrationsError(
            f"demonstrations: the {states.shape[0]} demonstrations do not vary at {flat} of "
            f"{states.shape[1]} steps (e.g. step {step}: largest standard deviation across them "
            f"{spread[step]:.3g}); a prior needs demonstrations that differ by at least "
            f"{MIN_SPREAD:g} at every step (identical demonstrations give zero variance)")


def _stack_states(positions: object, velocities: object, time: object, names: tuple[str, str],
                  axes: int | None) -> tuple[np.ndarray, np.ndarray]:
    """Validate (M, T, A) positions and velocities and (T,) time -> states (M, T, 2A), time."""
    p = as_array(positions, names[0], (None, None, axes), MAX_COORDINATE)
    v = as_array(velocities, names[1], p.shape, MAX_COORDINATE)
    t = as_time(time, "time", p.shape[1])
    return np.concatenate([p, v], axis=2), t


def learn_prior(demos: object = None, *, positions: np.ndarray | None = None,
                velocities: np.ndarray | None = None, time: np.ndarray | None = None,
                coupled: bool = False, ridge: float = 1e-6,
                jitter: float = 1e-12) -> WorkspacePrior:
    """Learn CLAMP's workspace prior over x = [p, v] (D = 6) from demonstrations.

    demos: a ``scenes.Demonstrations`` (anything with ``positions`` (M, T, 3) m,
    ``velocities`` (M, T, 3) m/s and ``time`` (T,) s); or give those three arrays by keyword.
    coupled: regress the full 6-vector instead of each axis's [p_d, v_d] separately.
    ridge: Frobenius penalty on every Phi_i (>= 0; 0 needs M >= 3 per axis, M >= 7 coupled).
    jitter: added to the diagonal of every Q_i and of cov0 so they are positive definite.
    Raises InsufficientDemonstrationsError (M < 2, ...), ShapeError, NonFiniteError.
    """
    if demos is not None:
        if any(a is not None for a in (positions, velocities, time)):
            raise InvalidParameterError("demos: give either a Demonstrations object or the "
                                        "positions/velocities/time arrays, not both")
        missing = [a for a in ("positions", "velocities", "time") if not hasattr(demos, a)]
        if missing:
            raise ShapeError(f"demos: expected a scenes.Demonstrations with attributes "
                             f"positions, velocities, time; {type(demos).__name__} lacks {missing}")
        positions, velocities, time = demos.positions, demos.velocities, demos.time
    elif positions is None or velocities is None or time is None:
        raise InvalidParameterError("demos: expected a Demonstrations object, or all of "
                                    "positions (M, T, 3), velocities (M, T, 3), time (T,)")
    states, t = _stack_states(positions, velocities, time, ("positions", "velocities"), 3)
    prior = _learn(states, t, coupled=coupled, ridge=ridge, jitter=jitter,
                   prior_class=WorkspacePrior, kind=WorkspacePrior.default_kind, state_names=None)
    return cast(WorkspacePrior, prior)


def learn_joint_prior(q: np.ndarray, qdot: np.ndarray, time: np.ndarray, *,
                      coupled: bool = False, ridge: float = 1e-6,
                      jitter: float = 1e-12) -> LinearGaussianPrior:
    """Learn a configuration-space prior over theta = [q, qdot] (D = 2n) (paper section 4.2).

    q (M, T, n) rad, qdot (M, T, n) rad/s, time (T,) s. Per joint by default (block-diagonal
    [q_j, qdot_j] blocks); same options and errors as :func:`learn_prior`.
    Returns a LinearGaussianPrior of kind "joint" with state names q0.., qdot0...
    """
    states, t = _stack_states(q, qdot, time, ("q", "qdot"), None)
    n = states.shape[2] // 2
    if n < 1:
        raise ShapeError("q: expected at least one joint, got shape (M, T, 0)")
    names = tuple(f"q{j}" for j in range(n)) + tuple(f"qdot{j}" for j in range(n))
    return _learn(states, t, coupled=coupled, ridge=ridge, jitter=jitter,
                  prior_class=LinearGaussianPrior, kind="joint", state_names=names)
