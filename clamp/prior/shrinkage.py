"""How a learned prior carries a moved start through the motion: start-offset shrinkage.

Conditioned on a start position p_0 = s, the prior's mean is the demonstrations' mean plus the
chain's response to the offset d = s - mean_0: mean_t + R_t d, with R_0 = cov0[:, p] cov0[p, p]^-1
(the state the start implies) and R_{t+1} = Phi_t R_t. Fitted per step from 3-10 samples, the
composed Phi_t ... Phi_0 is noisy: on the LASA shapes, whose demonstrations all converge to one
end, the moved start's offset wanders instead of fading out.

The response is therefore shrunk towards fading ones, each removing the offset linearly by the
end at the latest and never growing it (position part per axis; velocity part its time
derivative; tau the normalised time):

* ``spread``: F_t = (1 - tau_t) min(1, s_t / s_0), s_t the demonstrations' standard deviation
  (an offset never wider, relative to the spread, than at the start);
* ``regressed``: F_t = min(1 - tau_t, min_{k <= t} clip(g_k, 0, 1)), g_t the demonstrations'
  own start gain, the least-squares slope of their deviation from the mean at step t on their
  start offset (per axis, through the origin): the offset kept as long as the demonstrations
  keep theirs (the synthetic skills lose it within a third of the motion), as a non-increasing
  envelope (a single step where the noisy slope dips ends it);

Where every demonstration holds still (:func:`clamp.prior.demonstration_states.held_steps`,
e.g. the hand held in place through a pour), tau stands still (:func:`progress`): both shapes
have faded by the time the hold begins when it lasts to the end, and a held offset stays held.
Without a held step tau is the normalised time, bit for bit.

blended with non-negative weights of sum at most 1:

    R^w_t = R_t + sum_k w_k (F^k_t - R_t)          (t >= 1; R^w_0 = R_0),

and the transitions are corrected so that the chain propagates R^w:
Phi'_t = Phi_t + (R^w_{t+1} - Phi_t R^w_t) (R^w_t' R^w_t + eps I)^-1 R^w_t' (eps = DAMPING times
R_0's size: where the response has faded the correction fades instead of dividing by ~0), and
u'_t = mean_{t+1} - Phi'_t mean_t keeps the prior's mean the demonstrations' mean. The initial
velocity's response to the start (R_0's velocity part, the regression of 3-10 first velocities
on first positions, the noisiest estimate of the chain: with 3 demonstrations a 1 cm offset
implied 0.45 m/s more on pick_place, which the arm could not follow) is blended alike, towards
none (each shape starts at the demonstrations' mean initial velocity), and written into cov0
(its velocity-position block; the velocity's variance given the position kept), so that
conditioning the prior on a start, and the planner's start factor, which takes the velocity
that conditioning gives, start the shrunk response. (Towards each shape's own initial velocity,
the time derivative of its gain, gave the same within 0.3 mm of DTW on bench_lfd.) Q and the
initial mean are unchanged. A correction of rank A (one direction per axis): deviations that
are not a start offset are propagated as learned.

The weights are chosen from the demonstrations themselves: for every demonstration m, the chain
learned from the others predicts m from m's start, mean_t + R^w_t d_m; the squared error of
those leave-one-out predictions across the motion (the part of each error normal to the mean
path's direction at that step: demonstrations differ in speed, and an error along the path is
a timing difference, not a wrong shape; the path's direction is the gradient of the mean
positions, or for an orientation chain (``along="velocities"``) its mean angular velocity: its
tangent coordinates are centred on the mean rotation at every step, so their mean stays near 0
and its gradient is noise, while the mean rotation moves along Rbar^T omega, the chain's
velocity part; on bench_lfd's pose sets, conditional means, start / goal cells: wiping_rim 30.2
/ 24.1 -> 29.5 / 24.1 deg, pouring 2.31 / 1.94 -> 2.16 / 1.56, inserting 0.37 / 0.37 -> 0.33 /
0.32) is quadratic in w and its minimiser over the simplex
(w_k >= 0, sum w_k <= 1; the active sets are enumerated) is w. With the spread shape alone
the LASA shapes whose demonstrations keep their start offset far into the motion (NShape,
Zshape) were lost, and the synthetic skills that drop it within a third of the motion were
carried too far; the blend takes each shape where the held-out demonstrations show it
(conditional mean, bench_lfd: LASA 4.66 -> 4.60 mm, 9 -> 12 of 13 shapes; syn:reach_from_above
9.3 -> 8.2 mm). Adding a third shape, the plain linear fade 1 - tau, made it worse (11 of 13:
three weights from 5-6 demonstrations are noisier). With fewer than 3
demonstrations there is nothing to leave out, and the plain chain is a minimum-norm fit through
a single direction of variation: the spread fading response is taken whole (w_spread = 1), on
the norm of the spread instead of per axis (two demonstrations vary along one direction, whose
per-axis ratios s_t / s_0 are noise on an axis it barely moves), and followed closely
(damping FEW_DAMPING instead of DAMPING). On synthetic0 (folds of 2 demonstrations) the
conditional mean's DTW to the held-out demonstration is 5.68 -> 4.32 mm (TLGC 4.37); per axis
and closely followed 5.8, on the norm with DAMPING 5.53. A given weight w in [0, 1] is that of
the spread shape. The choice and its leave-one-out errors
are recorded in ``prior.info["start_shrinkage"]`` (``weight`` the total, ``weights`` per
shape).
"""
from __future__ import annotations

import itertools
import logging
from collections.abc import Callable
from typing import Any

import numpy as np

from clamp.errors import InvalidParameterError
from clamp.prior.chain import prefix_compose, start_response
from clamp.prior.demonstration_states import held_steps

__all__ = ["AUTO", "DAMPING", "FEW_DAMPING", "SHAPES", "PATH_DIRECTIONS", "as_shrinkage", "offset_responses",
           "fading_responses", "fading_shapes", "shrink_start_offsets"]

log = logging.getLogger(__name__)

#: ``start_shrinkage="auto"``: the weight chosen by leave-one-out prediction of the demonstrations.
AUTO = "auto"
#: The fading shapes the response is shrunk towards (module doc), in the order of the record.
SHAPES = ("spread", "regressed")
#: what gives the mean path's direction in the leave-one-out error: the gradient of the mean
#: positions (a workspace or joint chain), or the mean velocity part (an orientation chain)
PATH_DIRECTIONS = ("positions", "velocities")
#: Tikhonov damping of the correction, relative to the start response's size (see module doc).
DAMPING = 1e-2
#: the same with fewer than 3 demonstrations: the spread fading response followed closely
FEW_DAMPING = 1e-6

#: fit(index) -> (Phi (T-1, D, D), u (T-1, D), mean0 (D,), cov0 (D, D)) of the chain learned
#: from the demonstrations ``index``.
Fit = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]


def as_shrinkage(value: Any) -> str | float:
    """``"auto"`` or a weight in [0, 1]; InvalidParameterError naming start_shrinkage."""
    if isinstance(value, str) and value == AUTO:
        return AUTO
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not 0.0 <= float(value) <= 1.0:
        raise InvalidParameterError(f"start_shrinkage: expected 'auto' or a weight in [0, 1], "
                                    f"got {value!r}")
    return float(value)


def offset_responses(Phi: np.ndarray, u: np.ndarray, mean0: np.ndarray,
                     cov0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Chain mean (T, D) and response R (T, D, A) of the state to a unit start-position offset
    per axis (the start conditioned on its position, A = D / 2 position coordinates)."""
    start = start_response(cov0)                                          # (D, A)
    composed, shift, _ = prefix_compose(Phi, u, np.zeros_like(Phi))
    mean = np.concatenate([mean0[None], composed @ mean0 + shift])
    return mean, np.concatenate([start[None], composed @ start])


def progress(time: np.ndarray, held: np.ndarray | None = None) -> np.ndarray:
    """tau (T,): the normalised time, 0 at the start and 1 at the end; with ``held`` (T-1,)
    bool (:func:`clamp.prior.demonstration_states.held_steps`), counted over the steps where
    the demonstrations move only (constant through a hold: an offset is made up while they
    move). Without a held step, (time - time[0]) / (time[-1] - time[0]) exactly."""
    if held is None or not held.any() or held.all():
        return (time - time[0]) / float(time[-1] - time[0])
    moving = np.concatenate([[0.0], np.cumsum(np.where(held, 0.0, np.diff(time)))])
    return moving / moving[-1]


def fading_responses(time: np.ndarray, start: np.ndarray, positions: np.ndarray,
                     per_axis: bool = True, held: np.ndarray | None = None) -> np.ndarray:
    """The fading response F (T, D, A): position offset (1 - tau_t) min(1, s_t / s_0) per axis
    (s_t the demonstrations' standard deviation at step t: an offset never wider, relative to
    the spread, than at the start; where they all pass close it passes close), velocity its
    time derivative; F_0 = ``start`` (the state the start implies). positions (M, T, A);
    per_axis False: s_t the norm of the standard deviations, the same ratio on every axis;
    held (T-1,) the held steps, through which tau stands still (:func:`progress`)."""
    A = start.shape[1]
    tau = progress(time, held)
    spread = positions.std(axis=0)                                        # (T, A)
    if not per_axis:
        spread = np.repeat(np.linalg.norm(spread, axis=1, keepdims=True), A, axis=1)
    ratio = np.minimum(1.0, spread / np.where(spread[0] > 0, spread[0], np.inf))
    ratio[:, spread[0] <= 0] = 1.0
    gain = np.broadcast_to((1.0 - tau)[:, None] * ratio, (len(time), A))

    return _as_response(gain, time, start)


def _as_response(gain: np.ndarray, time: np.ndarray, start: np.ndarray) -> np.ndarray:
    """Response (T, D, A) with position gain (T, A) per axis, velocity its time derivative;
    state 0: the position part of ``start`` (D, A), no velocity (a moved start leaves the
    initial velocity the demonstrations' mean one)."""
    T, A = gain.shape
    out = np.zeros((T, start.shape[0], A))
    out[:, np.arange(A), np.arange(A)] = gain
    out[:, A + np.arange(A), np.arange(A)] = np.gradient(gain, time, axis=0)
    out[0] = 0.0
    out[0, :A] = start[:A]
    return out


def fading_shapes(time: np.ndarray, start: np.ndarray, positions: np.ndarray,
                  held: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """The fading responses of SHAPES (each (T, D, A); module doc) for the demonstrations'
    positions (M, T, A) and the state ``start`` (D, A) the start implies; held (T-1,) the
    steps they hold still (:func:`progress`)."""
    tau = progress(time, held)
    A = start.shape[1]
    remaining = np.repeat((1.0 - tau)[:, None], A, axis=1)
    deviation = positions - positions.mean(axis=0)
    offset = deviation[:, 0]                                              # (M, A)
    size = np.sum(offset * offset, axis=0)
    slope = np.einsum("mta,ma->ta", deviation, offset) / np.where(size > 0, size, np.inf)
    slope[:, size <= 0] = 1.0                             # no start spread: nothing to learn
    kept = np.minimum.accumulate(np.clip(slope, 0.0, 1.0), axis=0)
    return {"spread": fading_responses(time, start, positions, held=held),
            "regressed": _as_response(np.minimum(remaining, kept), time, start)}


def _simplex_minimiser(G: np.ndarray, c: np.ndarray) -> np.ndarray:
    """w minimising w' G w - 2 c' w over w >= 0, sum w <= 1 (G (K, K) positive semi-definite,
    K small): every active set is tried, interior and on the face sum w = 1."""
    K = len(c)
    best, value = np.zeros(K), 0.0
    for size in range(1, K + 1):
        for free in map(list, itertools.combinations(range(K), size)):
            Gf, cf = G[np.ix_(free, free)], c[free]
            systems = [(Gf, cf),
                       (np.block([[Gf, np.ones((size, 1))], [np.ones((1, size)), np.zeros((1, 1))]]),
                        np.append(cf, 1.0))]
            for matrix, rhs in systems:
                try:
                    solution = np.linalg.solve(matrix, rhs)[:size]
                except np.linalg.LinAlgError:
                    continue
                w = np.zeros(K)
                w[free] = solution
                if np.any(w < -1e-12) or w.sum() > 1.0 + 1e-9:
                    continue
                w = np.clip(w, 0.0, None)
                candidate = float(w @ G @ w - 2.0 * c @ w)
                if candidate < value:
                    best, value = w, candidate
    return best


def _corrected(Phi: np.ndarray, mean: np.ndarray, target: np.ndarray, damping: float = DAMPING
               ) -> tuple[np.ndarray, np.ndarray]:
    """Transitions that propagate ``target`` (T, D, A) (damped by ``damping`` relative to its
    start's size), and biases keeping ``mean``."""
    before, after = target[:-1], target[1:]
    gram = np.swapaxes(before, 1, 2) @ before
    size = np.trace(target[0].T @ target[0]) / target.shape[2]
    inverse = np.linalg.solve(gram + damping * size * np.eye(target.shape[2]),
                              np.swapaxes(before, 1, 2))                  # (T-1, A, D)
    Phi = Phi + (after - Phi @ before) @ inverse
    u = mean[1:] - np.einsum("tij,tj->ti", Phi, mean[:-1])
    return Phi, u


def _normal_part(vectors: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """vectors (T, A) less their components along the unit directions of ``direction`` (T, A)
    (left whole where the direction vanishes)."""
    size = np.linalg.norm(direction, axis=1, keepdims=True)
    unit = np.divide(direction, size, out=np.zeros_like(direction), where=size > 0)
    return vectors - np.sum(vectors * unit, axis=1, keepdims=True) * unit


def _leave_one_out(states: np.ndarray, time: np.ndarray, fit: Fit, along: str
                   ) -> tuple[np.ndarray, float, float]:
    """(weights per SHAPES minimising the leave-one-out squared error normal to the mean path,
    rms of that error at w = 0 and at the weights) [m], of the demonstrations' states (M, T, D);
    the path's direction ``along`` one of PATH_DIRECTIONS (module doc)."""
    positions = states[..., :states.shape[2] // 2]
    M = len(positions)
    A = positions.shape[2]
    K = len(SHAPES)
    G, c, plain = np.zeros((K, K)), np.zeros(K), 0.0
    for m in range(M):
        Phi, u, mean0, cov0 = fit(np.flatnonzero(np.arange(M) != m))
        mean, R = offset_responses(Phi, u, mean0, cov0)
        others = np.delete(states, m, axis=0)
        shapes = fading_shapes(time, R[0], others[..., :A], held_steps(others))
        offset = positions[m, 0] - mean[0, :A]
        direction = (np.gradient(mean[:, :A], axis=0) if along == "positions"
                     else mean[:, A:])                                    # along the path
        residual = _normal_part(positions[m] - mean[:, :A] - R[:, :A] @ offset, direction)
        steps = np.stack([_normal_part((shapes[name][:, :A] - R[:, :A]) @ offset, direction)
                          for name in SHAPES])                            # (K, T, A)
        G += np.einsum("kta,lta->kl", steps, steps)
        c += np.einsum("ta,kta->k", residual, steps)
        plain += float(np.sum(residual * residual))
    weights = _simplex_minimiser(G, c)
    count = M * positions.shape[1]
    chosen = plain - 2.0 * float(c @ weights) + float(weights @ G @ weights)
    return weights, float(np.sqrt(plain / count)), float(np.sqrt(max(chosen, 0.0) / count))


def shrink_start_offsets(states: np.ndarray, time: np.ndarray, Phi: np.ndarray, u: np.ndarray,
                         mean0: np.ndarray, cov0: np.ndarray, shrinkage: str | float,
                         fit: Fit, along: str = "positions"
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
    """Phi, u, cov0 with the start-offset response shrunk (module doc: the initial velocity's
    response to the start too) and the record of the choice.

    states (M, T, D) the demonstrations; Phi, u, mean0, cov0 the chain learned from all of them;
    shrinkage "auto" or a weight in [0, 1]; fit(index) the same learner on a subset; along one
    of PATH_DIRECTIONS: what gives the mean path's direction in the leave-one-out error
    ("velocities" for an orientation chain, module doc).
    """
    if along not in PATH_DIRECTIONS:
        raise InvalidParameterError(f"along: expected one of {list(PATH_DIRECTIONS)}, got "
                                    f"{along!r}")
    M = len(states)
    A = states.shape[2] // 2
    record: dict[str, Any] = {"setting": shrinkage}
    weights = np.zeros(len(SHAPES))
    few = shrinkage == AUTO and M < 3
    if shrinkage == AUTO:
        if few:
            weights[0] = 1.0
            record["reason"] = (f"{M} demonstrations: at least 3 are needed to choose by "
                                "leave-one-out; the spread fading response (on the norm of "
                                "the spread) is taken whole and followed closely")
        else:
            weights, plain, chosen = _leave_one_out(states, time, fit, along)
            record.update(loo_rms_plain=plain, loo_rms=chosen,
                          reason=f"leave-one-out over {M} demonstrations: start-conditioned "
                          f"prediction rms normal to the path {plain:.4g} -> {chosen:.4g} "
                          "(position units: m in a workspace prior)")
    else:
        weights[0] = float(shrinkage)
        record["reason"] = "given (spread fading shape)"
    record.update(weight=float(weights.sum()),
                  weights={name: float(w) for name, w in zip(SHAPES, weights)})
    log.info("start shrinkage weights %s (%s)", record["weights"], record["reason"])
    if not np.any(weights):
        return Phi, u, cov0, record
    mean, R = offset_responses(Phi, u, mean0, cov0)
    held = held_steps(states)
    if few:
        target = fading_responses(time, R[0], states[..., :A], per_axis=False, held=held)
    else:
        shapes = fading_shapes(time, R[0], states[..., :A], held)
        target = R + sum(w * (shapes[name] - R) for name, w in zip(SHAPES, weights) if w)
    Phi, u = _corrected(Phi, mean, target, FEW_DAMPING if few else DAMPING)
    return Phi, u, _with_start_velocity(cov0, target[0, A:]), record


def _with_start_velocity(cov0: np.ndarray, gain: np.ndarray) -> np.ndarray:
    """cov0 (D, D) whose velocity conditioned on the start position p moves by ``gain`` (A, A)
    (p - mean0_p): the velocity-position block gain cov_pp, the velocity's own variance given
    the position kept (its Schur complement), so the matrix stays positive semi-definite; its
    smallest eigenvalue is lifted to cov0's (the learner's jitter floor) where it fell below."""
    A = gain.shape[0]
    pp, vp, vv = cov0[:A, :A], cov0[A:, :A], cov0[A:, A:]
    given = vv - start_response(cov0)[A:] @ vp.T                          # Schur complement
    out = np.array(cov0, dtype=float, copy=True)
    out[A:, :A] = gain @ pp
    out[:A, A:] = out[A:, :A].T
    out[A:, A:] = given + gain @ pp @ gain.T
    out = 0.5 * (out + out.T)
    lift = np.linalg.eigvalsh(cov0).min() - np.linalg.eigvalsh(out).min()
    return out + max(lift, 0.0) * np.eye(len(out))
