"""How a learned prior carries a moved start through the motion: start-offset shrinkage.

Conditioned on a start position p_0 = s, the prior's mean is the demonstrations' mean plus the
chain's response to the offset d = s - mean_0: mean_t + R_t d, with R_0 = cov0[:, p] cov0[p, p]^-1
(the state the start implies) and R_{t+1} = Phi_t R_t. Fitted per step from 3-10 samples, the
composed Phi_t ... Phi_0 is noisy: on the LASA shapes, whose demonstrations all converge to one
end, the moved start's offset wanders instead of fading out.

The response is therefore shrunk towards a fading one, the offset removed linearly over the
motion and never wider, relative to the demonstrations' spread, than at the start (position
part F_t = (1 - tau_t) min(1, s_t / s_0) per axis, s_t the demonstrations' standard deviation,
tau the normalised time; velocity part its time derivative):

    R^w_t = (1 - w) R_t + w F_t          (t >= 1; R^w_0 = R_0),

and the transitions are corrected so that the chain propagates R^w:
Phi'_t = Phi_t + (R^w_{t+1} - Phi_t R^w_t) (R^w_t' R^w_t + eps I)^-1 R^w_t' (eps = DAMPING times
R_0's size: where the response has faded the correction fades instead of dividing by ~0), and
u'_t = mean_{t+1} - Phi'_t mean_t keeps the prior's mean the demonstrations' mean. Q and the
initial state are unchanged. A correction of rank A (one direction per axis): deviations that
are not a start offset are propagated as learned.

The weight w is chosen from the demonstrations themselves: for every demonstration m, the chain
learned from the others predicts m from m's start, mean_t + R^w_t d_m; the squared error of
those leave-one-out predictions across the motion (the part of each error normal to the mean
path's direction at that step: demonstrations differ in speed, and an error along the path is
a timing difference, not a wrong shape) is quadratic in w and its minimiser (clipped to
[0, 1]) is w. With fewer than 3 demonstrations there is nothing to leave out, and the plain
chain is a minimum-norm fit through a single direction of variation: w = 1 (the fading
response). The choice and its leave-one-out errors are recorded in
``prior.info["start_shrinkage"]``.
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import numpy as np

from clamp.errors import InvalidParameterError
from clamp.prior.chain import prefix_compose

__all__ = ["AUTO", "DAMPING", "as_shrinkage", "offset_responses", "fading_responses",
           "shrink_start_offsets"]

log = logging.getLogger(__name__)

#: ``start_shrinkage="auto"``: the weight chosen by leave-one-out prediction of the demonstrations.
AUTO = "auto"
#: Tikhonov damping of the correction, relative to the start response's size (see module doc).
DAMPING = 1e-2

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
    D = len(mean0)
    A = D // 2
    start = cov0[:, :A] @ np.linalg.inv(cov0[:A, :A])                    # (D, A)
    composed, shift, _ = prefix_compose(Phi, u, np.zeros_like(Phi))
    mean = np.concatenate([mean0[None], composed @ mean0 + shift])
    return mean, np.concatenate([start[None], composed @ start])


def fading_responses(time: np.ndarray, start: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """The fading response F (T, D, A): position offset (1 - tau_t) min(1, s_t / s_0) per axis
    (s_t the demonstrations' standard deviation at step t: an offset never wider, relative to
    the spread, than at the start; where they all pass close it passes close), velocity its
    time derivative; F_0 = ``start`` (the state the start implies). positions (M, T, A)."""
    T, D, A = len(time), start.shape[0], start.shape[1]
    tau = (time - time[0]) / float(time[-1] - time[0])
    spread = positions.std(axis=0)                                        # (T, A)
    ratio = np.minimum(1.0, spread / np.where(spread[0] > 0, spread[0], np.inf))
    ratio[:, spread[0] <= 0] = 1.0
    gain = (1.0 - tau)[:, None] * ratio
    out = np.zeros((T, D, A))
    out[:, np.arange(A), np.arange(A)] = gain
    out[:, A + np.arange(A), np.arange(A)] = np.gradient(gain, time, axis=0)
    out[0] = start
    return out


def _corrected(Phi: np.ndarray, mean: np.ndarray, target: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """Transitions that propagate ``target`` (T, D, A) (damped), and biases keeping ``mean``."""
    before, after = target[:-1], target[1:]
    gram = np.swapaxes(before, 1, 2) @ before
    size = np.trace(target[0].T @ target[0]) / target.shape[2]
    inverse = np.linalg.solve(gram + DAMPING * size * np.eye(target.shape[2]),
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


def _leave_one_out(positions: np.ndarray, time: np.ndarray, fit: Fit
                   ) -> tuple[float, float, float]:
    """(w minimising the leave-one-out squared error normal to the mean path, rms of that
    error at w = 0 and at w) [m]."""
    M = len(positions)
    A = positions.shape[2]
    cross = square = plain = 0.0
    for m in range(M):
        Phi, u, mean0, cov0 = fit(np.flatnonzero(np.arange(M) != m))
        mean, R = offset_responses(Phi, u, mean0, cov0)
        F = fading_responses(time, R[0], np.delete(positions, m, axis=0))
        offset = positions[m, 0] - mean[0, :A]
        direction = np.gradient(mean[:, :A], axis=0)                      # along the path
        residual = _normal_part(positions[m] - mean[:, :A] - R[:, :A] @ offset, direction)
        step = _normal_part((F[:, :A] - R[:, :A]) @ offset, direction)
        cross += float(np.sum(residual * step))
        square += float(np.sum(step * step))
        plain += float(np.sum(residual * residual))
    weight = float(np.clip(cross / square, 0.0, 1.0)) if square > 0 else 0.0
    count = M * positions.shape[1]
    chosen = plain - 2.0 * weight * cross + weight**2 * square
    return weight, float(np.sqrt(plain / count)), float(np.sqrt(max(chosen, 0.0) / count))


def shrink_start_offsets(states: np.ndarray, time: np.ndarray, Phi: np.ndarray, u: np.ndarray,
                         mean0: np.ndarray, cov0: np.ndarray, shrinkage: str | float,
                         fit: Fit) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    """Phi, u with the start-offset response shrunk (module doc) and the record of the choice.

    states (M, T, D) the demonstrations; Phi, u, mean0, cov0 the chain learned from all of them;
    shrinkage "auto" or a weight in [0, 1]; fit(index) the same learner on a subset.
    """
    M = len(states)
    A = states.shape[2] // 2
    record: dict[str, Any] = {"setting": shrinkage}
    if shrinkage == AUTO:
        if M < 3:
            weight = 1.0
            record.update(weight=weight, reason=f"{M} demonstrations: at least 3 are needed "
                          "to choose by leave-one-out; the fading response is taken whole")
        else:
            weight, plain, chosen = _leave_one_out(states[..., :A], time, fit)
            record.update(weight=weight, loo_rms_plain=plain, loo_rms=chosen,
                          reason=f"leave-one-out over {M} demonstrations: start-conditioned "
                          f"prediction rms normal to the path {plain:.4g} -> {chosen:.4g} "
                          "(position units: m in a workspace prior)")
    else:
        weight = float(shrinkage)
        record.update(weight=weight, reason="given")
    log.info("start shrinkage weight %.3g (%s)", weight, record["reason"])
    if weight == 0.0:
        return Phi, u, record
    mean, R = offset_responses(Phi, u, mean0, cov0)
    target = (1.0 - weight) * R + weight * fading_responses(time, R[0], states[..., :A])
    target[0] = R[0]
    Phi, u = _corrected(Phi, mean, target)
    return Phi, u, record
