"""Exact conditioning of a learned linear-Gaussian prior on positions at some states.

A prior x_0 ~ N(m0, P0), x_{i+1} = Phi_i x_i + u_i + w_i, w_i ~ N(0, Q_i), observed at a few
states through p_k = H x_{i_k} + v_k (H picks the positions, v_k ~ N(0, r^2 I), r tiny) is,
given those observations, again a Markov chain with the same structure:

    x_0 | y ~ N(m0', P0'),   x_{i+1} | x_i, y ~ N(Phi'_i x_i + u'_i, Q'_i).

A backward information filter gives it: the likelihood of the observations at states
> i given x_{i+1} is exp(-0.5 x' L x + e' x) (information L, vector e); with
K = Q (I + L Q)^-1 = (Q^-1 + L)^-1 the conditioned step is Phi' = (I - K L) Phi,
u' = (I - K L) u + K e, Q' = (I - K L) Q = K, and the message passed back to x_i is L~ = (I + L Q)^-1 L,
e~ = (I + L Q)^-1 e, L_i = Phi' L~ Phi (+ H' H / r^2 if state i is observed),
e_i = Phi' (e~ - L~ u) (+ H' p / r^2). Between observed states the messages are carried in
one batched step through the composed transitions (log-depth scan), so only the loop over the
few observed states is sequential; the conditioned steps are batched over all states. The
messages and the conditioned chain are :func:`clamp.prior.chain.backward_messages` and
:func:`clamp.prior.chain.conditioned_chain`; this module builds the observations.

The planner plans with the conditioned prior when a goal or via points are asked for, so the
learned workspace GP family itself pulls the plan through them (a soft 1 mm factor alone loses
against the learned prior's micrometre-stiff end: misses of 12-44 mm for a 5 cm goal move),
while the target factors stay in the graph as well.

One exception to exactness: where the chain would carry a goal offset to a state farther than
the goal itself moved (a few demonstrations fitted exactly), that state's response is capped
to the goal's (:mod:`clamp.prior.goal_response`; recorded in ``info["goal_response"]``). The
orientation chain of a pose prior, conditioned on a goal rotation, is capped alike (in its
tangent coordinates; measured in docs/decisions.md#pose-prior).
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from clamp.errors import ClampTypeError, InvalidParameterError, ShapeError
from clamp.prior import chain, goal_response
from clamp.prior import so3
from clamp.prior.linear_gaussian import WorkspacePrior, check_prior
from clamp.prior.orientation_prior import OrientationPrior
from clamp.validation import as_array, as_count, as_scalar
from skillplan.validation import MAX_COORDINATE, as_sequence


def condition_prior(prior: Any, observations: Sequence[tuple[int, Any]],
                    sigma: float = 1e-5) -> WorkspacePrior:
    """The workspace prior conditioned on end-effector positions at some states.

    prior: a WorkspacePrior (or anything with time, Phi, u, Q, mean0, cov0); observations:
    (state index, position (3,) [m]) pairs (an index may repeat: both count); sigma [m]: the
    observation noise (small: the conditioned mean meets each position to ~sigma when the
    prior's own spread there is much larger). Returns a new WorkspacePrior whose info records
    the conditioning; the original is unchanged.
    """
    check_prior(prior)
    sigma = as_scalar(sigma, "sigma", strictly_positive=True)
    observations = as_sequence(observations, "observations", "a list of pairs (state index, "
                               "position (3,))", ClampTypeError)
    T, A = len(prior.Phi) + 1, np.shape(prior.Phi)[1] // 2
    checked = []
    for k, item in enumerate(observations):
        if not isinstance(item, (tuple, list)) or len(item) != 2:
            raise ShapeError(f"observations[{k}]: expected a pair (state index, position "
                             f"({A},)), got {item!r:.60}")
        index, position = item
        if not 0 <= as_count(index, f"observations[{k}] index", minimum=0) < T:
            raise InvalidParameterError(f"observations[{k}]: expected a state index in "
                                        f"[0, {T}), got {index}")
        checked.append((int(index), as_array(position, f"observations[{k}] position", (A,),
                                             limit=MAX_COORDINATE)))
    return conditioned(prior, checked, sigma)


def conditioned(prior: WorkspacePrior, observations: Sequence[tuple[int, np.ndarray]],
                sigma: float) -> WorkspacePrior:
    """:func:`condition_prior` on checked inputs (a learned prior, (index, position (A,))
    pairs with indices in range, sigma > 0): what the planner calls on its request's targets.
    A goal's response is capped where it would amplify (module doc)."""
    info = {**getattr(prior, "info", {}), "conditioned_on": _observed(observations),
            "conditioning_sigma": sigma}
    exact = WorkspacePrior(prior.time, *_conditioned_chain(prior, observations, sigma),
                           info=info, orientation=getattr(prior, "orientation", None))
    return _goal_capped(prior, exact, observations, sigma)


def _goal_capped(prior: Any, exact: Any, observations: Sequence[tuple[int, np.ndarray]],
                 sigma: float) -> Any:
    """``exact`` (``prior`` conditioned exactly on ``observations``) with the response to an
    observation at the last state capped where it would amplify (:mod:`clamp.prior.goal_response`,
    recorded in ``info["goal_response"]``); ``exact`` itself without a goal."""
    T = exact.T
    if not any(index == T - 1 for index, _ in observations):
        return exact
    others = [(index, p) for index, p in observations if index != T - 1]
    Phi, u, Q, mean0, cov0 = _conditioned_chain(prior, others, sigma)
    rest_mean, rest_cov = chain.marginals(Phi, u, Q, mean0, cov0)
    scale = goal_response.goal_scale(Phi, rest_cov, sigma)
    exact.info["goal_response"] = goal_response.record(scale)
    if np.all(scale >= 1.0):
        return exact
    return exact.with_means(goal_response.capped_mean(rest_mean, np.asarray(exact.mean), scale,
                                                      np.asarray(exact.time)))


def conditioned_orientation(orientation: OrientationPrior,
                            observations: Sequence[tuple[int, np.ndarray]],
                            sigma: float) -> OrientationPrior:
    """The orientation chain of a pose prior conditioned exactly on the hand's rotations at
    some states: (state index, rotation (3, 3)) pairs, checked, observed in the tangent space
    of their step (r = log(Rbar_i^T R)) with noise ``sigma`` [rad]; the same backward filter
    as the positions' (module doc), and the same cap of a goal rotation's response where the
    chain would carry it back amplified (:mod:`clamp.prior.goal_response`: no state turns
    farther from where the others put it than the goal turned)."""
    tangent = [(int(i), so3.log_map(orientation.rotations[i].T @ np.asarray(R, dtype=float)))
               for i, R in observations]
    info = {**orientation.info, "conditioned_on": _observed(tangent), "conditioning_sigma": sigma}
    exact = OrientationPrior(orientation.time, *_conditioned_chain(orientation, tangent, sigma),
                             info=info)
    return _goal_capped(orientation, exact, tangent, sigma)


def _observed(observations: Sequence[tuple[int, np.ndarray]]) -> list[list]:
    """The observations as ``info["conditioned_on"]`` records them: [index, position list]."""
    return [[int(i), np.asarray(p, dtype=float).tolist()] for i, p in observations]


def _conditioned_chain(prior: WorkspacePrior, observations: Sequence[tuple[int, np.ndarray]],
                       sigma: float) -> tuple[np.ndarray, ...]:
    """(Phi, u, Q, mean0, cov0) of the chain conditioned exactly on the observations (module
    doc), Q and cov0 floored."""
    Phi, u, Q = (np.asarray(a, dtype=float) for a in (prior.Phi, prior.u, prior.Q))
    T, D = len(Phi) + 1, Phi.shape[1]
    A = D // 2
    L_obs = np.zeros((T, D, D))
    e_obs = np.zeros((T, D))
    for index, p in observations:
        L_obs[index, np.arange(A), np.arange(A)] += 1.0 / sigma**2
        e_obs[index, :A] += p / sigma**2
    L_msg, e_msg = chain.backward_messages(Phi, u, Q, L_obs, e_obs)
    P0, m0 = np.asarray(prior.cov0, dtype=float), np.asarray(prior.mean0, dtype=float)
    Phi_c, u_c, Q_c, mean0, cov0 = chain.conditioned_chain(Phi, u, Q, m0, P0, L_msg, e_msg)
    return Phi_c, u_c, _floor(Q_c, sigma), mean0, _floor(cov0[None], sigma)[0]


def same_pattern(conditioned_prior: Any, observations: Sequence[tuple[int, Any]],
                 sigma: float) -> bool:
    """Whether ``conditioned_prior`` (its ``info``) was conditioned at the state indices of
    ``observations``, in the same order, with the same ``sigma``, and, where its goal's
    response was capped, at the same positions but the goal's (then :func:`retargeted`
    applies)."""
    info = getattr(conditioned_prior, "info", {})
    before = info.get("conditioned_on")
    if (before is None or info.get("conditioning_sigma") != sigma
            or len(before) != len(observations)
            or any(int(i) != int(j) for (i, _), (j, _) in zip(before, observations))):
        return False
    if "scale" not in info.get("goal_response", {}):
        return True
    last = len(conditioned_prior.time) - 1
    return all(np.array_equal(np.asarray(p, dtype=float), np.asarray(q, dtype=float))
               for (i, p), (_, q) in zip(before, observations) if int(i) != last)


def retargeted(conditioned_prior: WorkspacePrior, observations: Sequence[tuple[int, np.ndarray]]
               ) -> WorkspacePrior:
    """:func:`conditioned` for the positions of ``observations`` ((index, position (A,))
    pairs, checked), from ``conditioned_prior``: the same learned prior conditioned on
    positions at the same state indices, in the same order, with the same sigma (its
    ``info``), e.g. the previous plan's before the goal moved. The information L of the
    messages, hence Phi', Q', cov0' and the marginal covariances, depends on where and how
    closely the chain is observed, not on the positions; the information vector e is linear
    in them, and its change de carried back through one step is Phi'^T de (the module
    docstring's (I + L Q)^-1 is (I - K L)^T), so only the offsets and means move:
    u' += Q' de_{i+1}, mean0' += cov0' de_0 (Q' and cov0' floored as :func:`conditioned`
    leaves them: a change below 1e-3 sigma^2 de, nanometres). Where the goal's response was
    capped (:mod:`clamp.prior.goal_response`) only the goal may move, and the mean's change is
    capped by the same scale. One backward pass, ~5x cheaper than conditioning again.
    InvalidParameterError when :func:`same_pattern` does not hold."""
    info = getattr(conditioned_prior, "info", {})
    before, sigma = info.get("conditioned_on"), info.get("conditioning_sigma")
    if sigma is None or not same_pattern(conditioned_prior, observations, sigma):
        raise InvalidParameterError(
            "conditioned_prior: expected a prior conditioned on positions at the states "
            f"{[int(j) for j, _ in observations]} (where its goal response was capped, at the "
            f"same positions but the goal's), got one conditioned on "
            f"{None if before is None else [int(i) for i, _ in before]}")
    Phi, Q = np.asarray(conditioned_prior.Phi), np.asarray(conditioned_prior.Q)
    T, D = len(Phi) + 1, Phi.shape[1]
    A = D // 2
    de_obs = np.zeros((T, D))
    for (index, p), (_, p_before) in zip(observations, before):
        de_obs[index, :A] += (np.asarray(p, dtype=float) - np.asarray(p_before)) / sigma**2
    de = np.empty((T, D))
    de[-1] = de_obs[-1]
    for i in range(T - 2, -1, -1):
        de[i] = Phi[i].T @ de[i + 1] + de_obs[i]
    du = np.einsum("tij,tj->ti", Q, de[1:])
    dmean0 = np.asarray(conditioned_prior.cov0) @ de[0]
    record = {**info, "conditioned_on": _observed(observations)}
    scale = info.get("goal_response", {}).get("scale")
    if scale is None:
        return conditioned_prior.with_offsets(np.asarray(conditioned_prior.u) + du,
                                              np.asarray(conditioned_prior.mean0) + dmean0,
                                              record)
    change = goal_response.capped_mean(np.zeros((T, D)), chain.forward_means(Phi, du, dmean0),
                                       np.asarray(scale), np.asarray(conditioned_prior.time))
    return conditioned_prior.with_means(np.asarray(conditioned_prior.mean) + change, record)


def _floor(cov: np.ndarray, sigma: float) -> np.ndarray:
    """Covariances (..., D, D) with eigenvalues below (1e-3 sigma)^2 raised to it: the
    conditioned noise of an observed coordinate is ~sigma^2 and round-off must not make it
    indefinite."""
    floor = (1e-3 * sigma) ** 2
    w, V = np.linalg.eigh(cov)
    if np.all(w >= floor):
        return cov
    w = np.maximum(w, floor)
    out = (V * w[..., None, :]) @ np.swapaxes(V, -1, -2)
    return 0.5 * (out + np.swapaxes(out, -1, -2))
