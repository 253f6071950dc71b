"""How a prior conditioned on a goal carries the moved goal back through the motion: never
farther than the goal moved.

Conditioned exactly on its start (and via points) and on a goal position g at the last state,
the prior's mean is the mean conditioned on the others plus the chain's response to the goal
offset d = g - m_T (m_T where the others alone put the end):

    m_t + G_t d,      G_t = Cov(x_t, p_T) Cov(p_T)^-1     (covariances given the others).

Learned per step from a few demonstrations, G can amplify: from 3 demonstrations (3 samples
for the 3 unknowns of each per-axis step) the regression fits them exactly, Q is tiny mid-motion
and large on the first step's velocity, and the chain explains 1 cm of goal by a swing of up to
12 cm mid-motion (pick_place's folds in bench_lfd; box_closing and needle_threading, 4-6
demonstrations: at most 1.5x). No demonstration does that: a goal offset is made up on the way,
not by swinging out and back.

The response is therefore capped per state: where the largest gain of G_t's position block
(its spectral norm, the most any goal direction is amplified) exceeds 1, the state's response
is scaled by s_t = 1 / ||G_t^p||_2, so no state of the path moves farther than the goal moved;
the velocities follow the scaled positions (s_t G^v_t + ds_t/dt G^p_t). The start and the via
points (G ~ 0 there) and the goal (G ~ I) keep their exact values. The scale depends on where
the chain is observed, not on the positions, so the capped mean stays linear in the targets.
Where no state amplifies (s = 1 everywhere) the conditioned prior is exactly the conditioned
chain. Only the means move: the conditioned chain's Phi, Q and cov0 are kept, its offsets u
carry the capped mean (u_t = m'_{t+1} - Phi_t m'_t).

Measured on bench_lfd's goal setting (conditional means, mean DTW over the folds): pick_place
34.88 -> 32.40 mm (DMP 33.75), needle_threading 9.76 -> 9.74, box_closing 9.63 -> 9.34, the
synthetic skills equal or better but syn:box_closing 8.82 -> 8.90. Capping each state's
response to the goal's own offset instead (direction by direction, not linear in the targets):
pick_place 31.46, box_closing 9.57; blending the response towards a linear fade-in by a
leave-one-out weight lost needle_threading (9.76 -> 20.4: the weight learned from 2 of 3
demonstrations).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from clamp.prior import chain

__all__ = ["goal_scale", "capped_mean", "record"]


def goal_scale(rest_Phi: np.ndarray, rest_cov: np.ndarray, sigma: float) -> np.ndarray:
    """Per-state scale s (T,) in (0, 1] of the response to a goal position at the last state.

    rest_Phi (T-1, D, D), rest_cov (T, D, D): the transitions of the chain conditioned on the
    other observations and its marginal covariances; sigma [m] the goal's observation noise.
    G_t = P_t A_t^T H^T (H P_T H^T + sigma^2 I)^-1 with A_t the composed steps t -> T-1
    (:func:`clamp.prior.chain.suffix_products`), H the position rows; s_t = min(1, 1 /
    ||G_t^p||_2).
    """
    T, D = rest_cov.shape[:2]
    A = D // 2
    composed = chain.suffix_products(rest_Phi)
    to_end = np.concatenate([composed, np.eye(D)[None]])[:, :A, :]          # (T, A, D)
    cross = rest_cov @ np.swapaxes(to_end, 1, 2)                               # (T, D, A)
    end = rest_cov[-1, :A, :A] + sigma**2 * np.eye(A)
    gain = np.linalg.solve(end, np.swapaxes(cross, 1, 2))                      # G^T (T, A, D)
    largest = np.linalg.norm(gain[:, :, :A], ord=2, axis=(1, 2))
    return np.minimum(1.0, 1.0 / np.maximum(largest, np.finfo(float).tiny))


def capped_mean(rest_mean: np.ndarray, exact_mean: np.ndarray, scale: np.ndarray,
                time: np.ndarray) -> np.ndarray:
    """The conditioned mean (T, D) with the goal's response scaled per state (module doc).

    rest_mean, exact_mean (T, D): the means conditioned on the other observations and on all
    of them (the goal's response is their difference); scale (T,); time (T,) [s].
    """
    A = rest_mean.shape[1] // 2
    response = exact_mean - rest_mean
    rate = np.gradient(scale, time)
    capped = response * scale[:, None]
    capped[:, A:] += rate[:, None] * response[:, :A]
    return rest_mean + capped


def record(scale: np.ndarray) -> dict[str, Any]:
    """What the cap did, for the conditioned prior's ``info["goal_response"]``: the states
    scaled (s < 1), the largest gain (1 / min s) and, where any was, the scale itself (a list,
    for :func:`clamp.prior.conditioning.retargeted`)."""
    scaled = np.flatnonzero(scale < 1.0)
    out: dict[str, Any] = {"capped_states": int(len(scaled)),
                           "largest_gain": float(1.0 / scale.min())}
    if len(scaled):
        out.update(first=int(scaled[0]), last=int(scaled[-1]), scale=scale.tolist())
    return out
