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

``method="incremental"`` learns the same per-step, per-group regressions with the reference's
conjugate Bayesian model instead (:mod:`clamp.prior.conjugate`); the prior keeps the posterior and
``prior.update(demos)`` continues from it.

Demonstrations that agree exactly at some steps (a common start, a common goal reached at
rest) give a zero residual there, which would make the prior singular. At every step where
the demonstrations' largest standard deviation over the state's coordinates is below
SPREAD_FLOOR = 1e-5 (0.01 mm on positions, 0.01 mm/s on velocities; rad and rad/s in a joint
prior), the diagonal entries are raised to at least SPREAD_FLOOR**2: of Q_i when that step is
x_{i+1}, of the initial covariance when it is x_0 (after the jitter). Such a step is learned
as "every demonstration is here, within 0.01 mm", a precision the planner's solver and
posterior covariance handle (the reference's 1e-12 alone leaves them singular; on the Jaco a
plan from a new start then fails its posterior covariance). Steps where the demonstrations
differ in some coordinate (e.g. all at rest at different places, as the synthetic skills
start and end) are learned exactly as before. Only demonstrations identical at every step
are refused.

Demonstrations that all hold still over a step, each where it is (a pour turns the hand in
place: every demonstration's position is unchanged for the last third of the skill and its
velocity zero; :func:`clamp.prior.demonstration_states.held_steps`), are fitted exactly there
by holding: x_{i+1} = x_i on the positions, zero velocity. The ridge would pull that slope
towards zero (s^2 / (s^2 + ridge) = 0.97 where the demonstrations hold a few millimetres
apart), and a start or goal offset would then be carried into the hold only in part: the
conditioned mean drifted through the held pour by 1-6 mm. A held step is learned as that exact
fit (Phi holds the positions and zeroes the velocities; the residual, hence Q, is the jitter
and the agreement floor), and the start shrinkage's fading shapes
(:mod:`clamp.prior.shrinkage`) fade only while the demonstrations move. Demonstrations that
never hold still exactly (every recording and every position-only skill of the benchmarks)
are learned as before, bit for bit.
"""
from __future__ import annotations

import logging
import warnings
from typing import Any, cast

import numpy as np

from clamp.errors import (ClampWarning, DegenerateDemonstrationsError,
                          InsufficientDemonstrationsError, InvalidParameterError, ShapeError)
from clamp.prior.conjugate import ConjugatePosterior
from clamp.prior.demonstration_states import (MIN_SPREAD, SPREAD_FLOOR, assemble_blocks,
                                              block_covariance, demo_arrays, held_steps,
                                              sample_weights, stack_states)
from clamp.prior.obstacle_weighting import ObstacleWeighting, as_weighting
from clamp.prior import so3
from clamp.prior.linear_gaussian import LinearGaussianPrior, WorkspacePrior
from clamp.prior.orientation_prior import OrientationPrior, orientation_states
from clamp.prior.shrinkage import as_shrinkage, shrink_start_offsets
from clamp.validation import as_array, as_bool, as_scalar, as_time
from clamp.prior.skill import SkillRegion

__all__ = ["learn_prior", "learn_orientation", "learn_joint_prior", "update_prior", "fit_transitions", "state_groups",
           "METHODS", "MIN_SPREAD", "SPREAD_FLOOR"]

log = logging.getLogger(__name__)


def state_groups(num_axes: int, coupled: bool) -> np.ndarray:
    """Index groups (G, k) into the state ``[positions (A), velocities (A)]`` regressed jointly.

    Per axis: G = A groups ``[d, A + d]``; coupled: one group with all D = 2A indices.
    """
    if coupled:
        return np.arange(2 * num_axes)[None, :]
    axes = np.arange(num_axes)
    return np.stack([axes, axes + num_axes], axis=1)


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


def _step_weights(weights: np.ndarray | None, M: int, T: int) -> np.ndarray:
    """Transition weights (T-1, M) from sample weights (M, T): the smaller of the two samples',
    scaled so every step's largest weight is 1 (all ones without weights)."""
    if weights is None:
        return np.ones((T - 1, M))
    step = np.minimum(weights[:, :-1], weights[:, 1:]).T
    top = step.max(axis=1, keepdims=True)
    return step / np.where(top > 0, top, 1.0)


def fit_transitions(states: np.ndarray, groups: np.ndarray, ridge: float, jitter: float,
                    weights: np.ndarray | None = None
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-step (weighted) ridge regression of x_{i+1} on [1, x_i] over M demonstrations.

    states (M, T, D); groups (G, k) index groups regressed jointly (see :func:`state_groups`);
    weights (M, T) per sample (None: unweighted; see :mod:`clamp.prior.obstacle_weighting`).
    Returns Phi (T-1, D, D), u (T-1, D), Q (T-1, D, D) with ``jitter`` on Q's diagonal, floored
    where the next states agree (:func:`clamp.prior.demonstration_states.floor_agreement`); Q is
    the weighted mean of the residuals' outer products.
    """
    M, T, D = states.shape
    w = _step_weights(weights, M, T)[:, None, :, None]  # (T-1, 1, M, 1)
    total = w.sum(axis=2, keepdims=True)
    # (T-1, G, M, k): one small regression per step and group, all solved in one batch.
    X = np.moveaxis(states[:, :-1][:, :, groups], 0, 2)
    Y = np.moveaxis(states[:, 1:][:, :, groups], 0, 2)
    x_bar = (w * X).sum(axis=2, keepdims=True) / total
    y_bar = (w * Y).sum(axis=2, keepdims=True) / total
    root = np.sqrt(w)
    Xc, Yc = root * (X - x_bar), root * (Y - y_bar)
    B = _ridge_fit(Xc, Yc, ridge)                      # (T-1, G, k, k): Phi_g^T
    held = held_steps(states)
    if held.any():                                     # hold exactly (module doc)
        B = np.where(held[:, None, None, None], np.diag(groups[0] < D // 2).astype(float), B)
    Phi_g = np.swapaxes(B, -1, -2)
    u_g = (y_bar - x_bar @ B)[..., 0, :]               # (T-1, G, k)
    R = Yc - Xc @ B
    Q_g = np.swapaxes(R, -1, -2) @ R / total
    spread_g = (Yc * Yc).sum(axis=2) / total[..., 0, :]   # (T-1, G, k) variance of x_{i+1}
    return assemble_blocks(Phi_g, u_g, Q_g, groups, D, jitter, spread_g)


def _initial_state(states: np.ndarray, groups: np.ndarray, jitter: float,
                   weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Weighted mean (D,) and biased covariance (D, D) of the first states, block-diagonal by
    group (weights (M, T) per sample, column 0 used; None: equal weights)."""
    x0 = states[:, 0]
    w = np.ones(len(x0)) if weights is None else weights[:, 0] / max(weights[:, 0].max(), 1e-300)
    mean0 = w @ x0 / w.sum()
    centred = x0 - mean0
    return mean0, block_covariance((centred * w[:, None]).T @ centred / w.sum(), groups, jitter)


METHODS = ("batch", "incremental")


def _learn(states: np.ndarray, time: np.ndarray, *, coupled: bool, ridge: float, jitter: float,
           prior_class: type[LinearGaussianPrior], kind: str,
           state_names: tuple[str, ...] | None, method: str = "batch",
           weights: np.ndarray | None = None,
           weighting: ObstacleWeighting | None = None,
           start_shrinkage: str | float = 0.0, along: str = "positions") -> LinearGaussianPrior:
    """Shared learner: states (M, T, D = 2A) ordered [positions, velocities] -> prior.

    weights (M, T) per sample (None: unweighted), weighting the settings that made them; along
    the start shrinkage's path direction (:data:`clamp.prior.shrinkage.PATH_DIRECTIONS`)."""
    ridge = as_scalar(ridge, "ridge", minimum=0.0)
    jitter = as_scalar(jitter, "jitter", minimum=0.0)
    if method not in METHODS:
        raise InvalidParameterError(f"method: expected one of {list(METHODS)}, got {method!r}")
    coupled = as_bool(coupled, "coupled")
    M, T, D = states.shape
    if M < 2:
        raise InsufficientDemonstrationsError(
            f"demonstrations: expected at least 2 demonstrations, got {M}")
    if T < 2:
        raise ShapeError(f"demonstrations: expected at least 2 time steps, got {T}")
    check_spread(states)
    groups = state_groups(D // 2, coupled)
    info: dict[str, Any] = {"method": method, "coupled": coupled, "jitter": jitter,
                            "num_demos": int(M),
                            "obstacle_weighting": weighting.to_dict() if weighting else None}
    if method == "incremental":
        # the conjugate prior (K0, S0) regularises every regression: no ridge, no minimum M
        posterior = ConjugatePosterior.empty(T - 1, D, groups).update(states, weights)
        return prior_class.from_posterior(posterior, time, jitter, kind=kind,
                                          state_names=state_names, info=info)
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
    Phi, u, Q = fit_transitions(states, groups, ridge, jitter, weights)
    mean0, cov0 = _initial_state(states, groups, jitter, weights)

    def refit(index: np.ndarray) -> tuple[np.ndarray, ...]:   # the learner on a subset
        sub = None if weights is None else weights[index]
        return (*fit_transitions(states[index], groups, ridge, jitter, sub)[:2],
                *_initial_state(states[index], groups, jitter, sub))
    Phi, u, cov0, info["start_shrinkage"] = shrink_start_offsets(
        states, time, Phi, u, mean0, cov0, as_shrinkage(start_shrinkage), refit, along)
    return prior_class(time, Phi, u, Q, mean0, cov0, kind=kind, info={**info, "ridge": ridge},
                       state_names=state_names)


def check_spread(states: np.ndarray) -> None:
    """Refuse demonstrations (M, T, D) that coincide at every step (spread below MIN_SPREAD);
    steps where they coincide (a common start or goal) are logged and learned with the floor."""
    states = as_array(states, "states", (None, None, None))
    spread = states.std(axis=0).max(axis=1)                    # (T,)
    flat = spread < MIN_SPREAD
    if np.all(flat):
        raise DegenerateDemonstrationsError(
            f"demonstrations: the {states.shape[0]} demonstrations are identical at all "
            f"{states.shape[1]} steps (largest standard deviation across them "
            f"{spread.max():.3g}); a prior needs demonstrations that differ by at least "
            f"{MIN_SPREAD:g} at some step (identical demonstrations teach no variation)")
    if np.any(flat):
        steps = np.flatnonzero(flat)
        log.info("demonstrations agree exactly at %d of %d steps (first %d, last %d): learned "
                 "with a spread floor of %g (m, m/s)", len(steps), len(spread), steps[0],
                 steps[-1], SPREAD_FLOOR)


def learn_prior(demos: object = None, *, positions: np.ndarray | None = None,
                velocities: np.ndarray | None = None, time: np.ndarray | None = None,
                coupled: bool = False, ridge: float = 1e-6, jitter: float = 1e-12,
                method: str = "batch", obstacle_weighting: Any = None,
                start_shrinkage: str | float = "auto") -> WorkspacePrior:
    """Learn CLAMP's workspace prior over x = [p, v] (D = 6) from demonstrations.

    demos: a ``scenes.Demonstrations`` (anything with ``positions`` (M, T, 3) m,
    ``velocities`` (M, T, 3) m/s and ``time`` (T,) s; ``obstacles``, per demonstration the
    obstacles recorded with it, are used by the weighting); or give the arrays by keyword.
    coupled: regress the full 6-vector instead of each axis's [p_d, v_d] separately.
    ridge: Frobenius penalty on every Phi_i (>= 0; 0 needs M >= 3 per axis, M >= 7 coupled).
    jitter: added to the diagonal of every Q_i and of cov0 so they are positive definite.
    method: "batch" (ridge regression) or "incremental" (the conjugate Bayesian model of
    :mod:`clamp.prior.conjugate`; the prior keeps its posterior, see ``WorkspacePrior.update``).
    obstacle_weighting: None, True (eps 0.3 m, sigma 0.001) or a clamp.ObstacleWeighting /
    dict: every sample weighted by its distance to its demonstration's own obstacles.
    start_shrinkage: how a moved start is carried through the motion (batch method,
    :mod:`clamp.prior.shrinkage`): "auto" (default) shrinks the chain's start-offset response towards
    a blend of two that fade to the demonstrations' mean (as their spread narrows; as their
    own start gain falls) by the weights that best predict every demonstration from its start
    when learned from the others; a weight in [0, 1] fixes that of the spread fade (0: the
    plain per-step regression). The choice is in ``prior.info["start_shrinkage"]``.
    Raises InsufficientDemonstrationsError (M < 2, ...), ShapeError, NonFiniteError.
    """
    positions, velocities, time, obstacles = demo_arrays(demos, positions, velocities, time)
    states, t = stack_states(positions, velocities, time, ("positions", "velocities"), 3)
    weighting = as_weighting(obstacle_weighting)
    prior = _learn(states, t, coupled=coupled, ridge=ridge, jitter=jitter,
                   prior_class=WorkspacePrior, kind=WorkspacePrior.default_kind, state_names=None,
                   method=method, weights=sample_weights(states, obstacles, weighting),
                   weighting=weighting, start_shrinkage=start_shrinkage)
    prior.info["skill_region"] = SkillRegion.from_positions(states[..., :3]).to_info()
    quaternions = getattr(demos, "orientations", None)
    if quaternions is None:
        return cast(WorkspacePrior, prior)
    orientation = learn_orientation(quaternions, t, coupled=coupled, ridge=ridge, jitter=jitter,
                                    method=method, start_shrinkage=start_shrinkage)
    return cast(WorkspacePrior, prior).with_orientation(orientation)


def learn_orientation(orientations: Any, time: Any, *, coupled: bool = False,
                      ridge: float = 1e-6, jitter: float = 1e-12, method: str = "batch",
                      start_shrinkage: str | float = "auto") -> OrientationPrior:
    """Learn the hand's orientation chain of a pose prior (:mod:`clamp.prior.orientation_prior`)
    from unit quaternions (M, T, 4) (x, y, z, w) sampled at ``time`` (T,) [s]: the states
    [log(Rbar_t^T R_t), Rbar_t^T omega_t] about the chordal mean rotations Rbar_t, learned with
    the same options as :func:`learn_prior` (no obstacle weighting: the weights are the
    positions'; the start shrinkage reads the mean path's direction from the mean angular
    velocity, :mod:`clamp.prior.shrinkage`)."""
    q = as_array(orientations, "orientations", (None, None, 4))
    t = as_time(time, "time", q.shape[1])
    rotations = so3.from_quaternions(q / np.linalg.norm(q, axis=-1, keepdims=True))
    mean = so3.chordal_mean(rotations)
    states = orientation_states(rotations, mean, t)
    chain = _learn(states, t, coupled=coupled, ridge=ridge, jitter=jitter,
                   prior_class=LinearGaussianPrior, kind=OrientationPrior.default_kind,
                   state_names=None, method=method, start_shrinkage=start_shrinkage,
                   along="velocities")
    return OrientationPrior.learned_at(chain, mean, states)


def update_prior(prior: LinearGaussianPrior, demos: object) -> LinearGaussianPrior:
    """The prior after more demonstrations: ``prior.update(demos)``."""
    return prior.update(demos)


def prior_from_posterior(posterior: ConjugatePosterior, time: np.ndarray, jitter: float,
                         prior_class: type[LinearGaussianPrior], kind: str,
                         state_names: tuple[str, ...] | None,
                         info: dict[str, Any]) -> LinearGaussianPrior:
    """``prior_class.from_posterior(...)`` (kept for callers of the former function)."""
    return prior_class.from_posterior(posterior, time, jitter, kind=kind,
                                      state_names=state_names, info=info)


def learn_joint_prior(q: np.ndarray, qdot: np.ndarray, time: np.ndarray, *,
                      coupled: bool = False, ridge: float = 1e-6, jitter: float = 1e-12,
                      method: str = "batch") -> LinearGaussianPrior:
    """Learn a configuration-space prior over theta = [q, qdot] (D = 2n) (paper section 4.2).

    q (M, T, n) rad, qdot (M, T, n) rad/s, time (T,) s. Per joint by default (block-diagonal
    [q_j, qdot_j] blocks); same options and errors as :func:`learn_prior`.
    Returns a LinearGaussianPrior of kind "joint" with state names q0.., qdot0...
    """
    states, t = stack_states(q, qdot, time, ("q", "qdot"), None)
    n = states.shape[2] // 2
    if n < 1:
        raise ShapeError("q: expected at least one joint, got shape (M, T, 0)")
    names = tuple(f"q{j}" for j in range(n)) + tuple(f"qdot{j}" for j in range(n))
    return _learn(states, t, coupled=coupled, ridge=ridge, jitter=jitter,
                  prior_class=LinearGaussianPrior, kind="joint", state_names=names,
                  method=method)
