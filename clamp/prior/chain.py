"""The algebra of a linear Gaussian chain, written once.

The chain over T states x_0 .. x_{T-1}, each a D-vector:

    x_0 ~ N(mean0, cov0),    x_{i+1} = Phi_i x_i + u_i + w_i,    w_i ~ N(0, Q_i),

with Phi (T-1, D, D), u (T-1, D), Q (T-1, D, D). Everything here works on these arrays (no
prior object) and is batched over the states with numpy, so the sequential Python loops run
over log2 T scan rounds or over the few observed states only (the RTS backward pass excepted):

* steps: an affine Gaussian step x -> A x + b + N(0, B) is a triple (A, b, B); steps compose
  associatively (:func:`compose`), so the running compositions of a chain come from a
  log-depth scan from either end (:func:`prefix_compose`, :func:`suffix_compose`) and one
  composition of many steps from a tree reduction (:func:`total_compose`);
* marginals: means (T, D) and covariances (T, D, D) of every state (:func:`marginals`);
* exact position observations: the Kalman update on the leading coordinates
  (:func:`observe_leading`), a filter that visits only the observed states and returns the
  observations' squared Mahalanobis distance (:func:`observation_d2`), the filter over every
  state (:func:`kalman_filter`) and the Rauch-Tung-Striebel smoother (:func:`rts_smooth`);
* noisy observations in information form: the backward messages (:func:`backward_messages`)
  and the chain they condition the prior into (:func:`conditioned_chain`).

The prior (:mod:`clamp.prior.linear_gaussian`), the plausibility score
(:mod:`clamp.prior.plausibility`) and the conditioning on targets
(:mod:`clamp.prior.conditioning`) call these. Each function keeps the order of its floating
point operations: the planner's plans are reproduced to the bit.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from scipy import linalg

Step = tuple[np.ndarray, np.ndarray, np.ndarray]
"""An affine Gaussian step (A, b, B): x -> A x + b + N(0, B); batched: A (S, D, D), b (S, D),
B (S, D, D)."""

Observations = Sequence[tuple[int, np.ndarray]]
"""(state index, target (K, count)) pairs, ascending by index, each index at most once."""


# ------------------------------------------------------------------------------ steps
def start_response(cov0: np.ndarray) -> np.ndarray:
    """The initial state's response (D, A) to its position, per unit of each of the A = D / 2
    position coordinates: N(mean0, cov0) conditioned on its position p moves by
    R (p - mean0_p), R = cov0[:, :A] cov0[:A, :A]^-1 (the position rows the identity)."""
    A = len(cov0) // 2
    return cov0[:, :A] @ np.linalg.inv(cov0[:A, :A])


def spread(A: np.ndarray, P: np.ndarray, B: np.ndarray) -> np.ndarray:
    """A P A^T + B (batched over leading axes): a covariance P carried through the step
    (A, ., B)."""
    return A @ P @ np.swapaxes(A, -1, -2) + B


def compose(late: Step, early: Step) -> Step:
    """Batched composition (A2, b2, B2) o (A1, b1, B1) = (A2 A1, A2 b1 + b2, A2 B1 A2^T + B2)
    of affine Gaussian steps (A (S, D, D), b (S, D), B (S, D, D)): ``early`` applied first."""
    (A2, b2, B2), (A1, b1, B1) = late, early
    return A2 @ A1, np.einsum("sij,sj->si", A2, b1) + b2, spread(A2, B1, B2)


def prefix_compose(Phi: np.ndarray, u: np.ndarray, Q: np.ndarray) -> Step:
    """Running compositions of the steps x -> Phi_i x + u_i, C -> Phi_i C Phi_i^T + Q_i.

    Phi (S, D, D), u (S, D), Q (S, D, D). Returns A (S, D, D), b (S, D), B (S, D, D) with
    ``mean_{i+1} = A_i mean_0 + b_i`` and ``cov_{i+1} = A_i cov_0 A_i^T + B_i``, i.e.
    A_i = Phi_i ... Phi_0. Hillis-Steele scan: ceil(log2 S) rounds of batched products.
    """
    A, b, B = Phi.copy(), u.copy(), Q.copy()
    shift = 1
    while shift < len(A):
        A[shift:], b[shift:], B[shift:] = compose((A[shift:], b[shift:], B[shift:]),
                                                  (A[:-shift], b[:-shift], B[:-shift]))
        shift *= 2
    return A, b, B


def suffix_compose(Phi: np.ndarray, u: np.ndarray, Q: np.ndarray) -> Step:
    """Compositions of the steps i..S-1 (as :func:`prefix_compose`, from the other end).

    Returns A (S, D, D), b (S, D), B (S, D, D) with x_S = A_i x_i + b_i + w, w ~ N(0, B_i)
    for x_{k+1} = Phi_k x_k + u_k + N(0, Q_k), i.e. A_i = Phi_{S-1} ... Phi_i (log depth).
    """
    A, b, B = Phi.copy(), u.copy(), Q.copy()
    shift = 1
    while shift < len(A):
        A[:-shift], b[:-shift], B[:-shift] = compose((A[shift:], b[shift:], B[shift:]),
                                                     (A[:-shift], b[:-shift], B[:-shift]))
        shift *= 2
    return A, b, B


def suffix_products(Phi: np.ndarray) -> np.ndarray:
    """The transitions of :func:`suffix_compose` alone: A_i = Phi_{S-1} ... Phi_i (S, D, D)."""
    A = Phi.copy()
    shift = 1
    while shift < len(A):
        A[:-shift] = A[shift:] @ A[:-shift]
        shift *= 2
    return A


def total_compose(Phi: np.ndarray, u: np.ndarray, Q: np.ndarray) -> Step:
    """The steps s = 0 .. S-1 (S >= 1) composed into one (A (D, D), b (D,), B (D, D)):
    x_S = A x_0 + b + N(0, B). Pairwise tree reduction: O(S) products in ceil(log2 S)
    batched calls (the last entry of :func:`prefix_compose`, in another rounding order)."""
    A, b, B = Phi, u, Q
    while len(A) > 1:
        n = len(A) - len(A) % 2
        nA, nb, nB = compose((A[1:n:2], b[1:n:2], B[1:n:2]), (A[0:n:2], b[0:n:2], B[0:n:2]))
        if n < len(A):
            nA, nb, nB = (np.concatenate([new, old[-1:]]) for new, old in
                          ((nA, A), (nb, b), (nB, B)))
        A, b, B = nA, nb, nB
    return A[0], b[0], B[0]


# ------------------------------------------------------------------------------ marginals
def forward_means(Phi: np.ndarray, u: np.ndarray, mean0: np.ndarray) -> np.ndarray:
    """The means (T, D) of the chain from mean0 (D,): mean_{i+1} = Phi_i mean_i + u_i, one
    step after the other (the exact sequence, cheaper than :func:`marginals` for means alone)."""
    mean = np.empty((len(Phi) + 1, len(mean0)))
    mean[0] = mean0
    for i in range(len(Phi)):
        mean[i + 1] = Phi[i] @ mean[i] + u[i]
    return mean


def marginals(Phi: np.ndarray, u: np.ndarray, Q: np.ndarray, mean0: np.ndarray,
              cov0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Marginal means (T, D) and (symmetrised) covariances (T, D, D) of every state.

    mean_{i+1} = Phi_i mean_i + u_i, cov_{i+1} = Phi_i cov_i Phi_i^T + Q_i, from the running
    compositions of :func:`prefix_compose`: O(T log T) work in ceil(log2 T) numpy calls.
    """
    A, b, B = prefix_compose(Phi, u, Q)
    mean = np.concatenate([mean0[None], A @ mean0 + b])
    cov = np.concatenate([cov0[None], spread(A, cov0, B)])
    return mean, 0.5 * (cov + np.swapaxes(cov, 1, 2))


# ------------------------------------------------------------------------------ exact observations
def observe_leading(m: np.ndarray, P: np.ndarray, target: np.ndarray,
                    count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Condition N(m (K, D), P) on the exact observation m[:, :count] = target (K, count).

    Returns the conditioned means (K, D) and covariance (zero in the observed rows and
    columns) and the innovations' squared Mahalanobis distance (K,) under their predictive
    covariance S = P[:count, :count].
    """
    S = P[:count, :count]
    factor = linalg.cho_factor(S, lower=True)
    e = target - m[:, :count]
    d2 = np.einsum("ka,ka->k", e, linalg.cho_solve(factor, e.T).T)
    G = linalg.cho_solve(factor, P[:count, :]).T             # (D, count) = P H^T S^{-1}
    m = m + e @ G.T
    P = P - G @ P[:count, :]
    P = 0.5 * (P + P.T)
    P[:count, :] = 0.0
    P[:, :count] = 0.0
    m[:, :count] = target
    return m, P, d2


def _filter(mean0: np.ndarray, cov0: np.ndarray, observations: Observations, count: int,
            advance: Callable[[int, int, np.ndarray, np.ndarray],
                              tuple[np.ndarray, np.ndarray]]
            ) -> tuple[np.ndarray, list[tuple[np.ndarray, np.ndarray]]]:
    """Kalman filter from N(mean0, cov0) through the observed states in ascending order.

    ``advance(i, j, m, P)`` carries the means (K, D) and covariance at state i to state j > i.
    Returns the observations' squared Mahalanobis distance (K,) (the sum of the innovations')
    and the filtered (means, covariance) at each observed state.
    """
    K = observations[0][1].shape[0] if observations else 1
    m = np.broadcast_to(mean0, (K, len(mean0))).copy()
    P = np.array(cov0)
    d2 = np.zeros(K)
    filtered = []
    previous = 0
    for index, target in observations:
        if index > previous:
            m, P = advance(previous, index, m, P)
        m, P, step = observe_leading(m, P, target, count)
        d2 += step
        filtered.append((m, P))
        previous = index
    return d2, filtered


def observation_d2(mean0: np.ndarray, cov0: np.ndarray, observations: Observations, count: int,
                   segment: Callable[[int, int], Step]) -> np.ndarray:
    """Squared Mahalanobis distance (K,) of exact observations of the leading ``count``
    coordinates under their prior marginal (prediction-error decomposition of their joint
    density): a Kalman filter that visits only the observed states, ``segment(i, j)`` giving
    the composed step x_i -> x_j (e.g. :func:`total_compose` of the steps i..j-1)."""
    def advance(i: int, j: int, m: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        A, b, B = segment(i, j)
        return m @ A.T + b, spread(A, P, B)

    return _filter(mean0, cov0, observations, count, advance)[0]


def kalman_filter(Phi: np.ndarray, u: np.ndarray, Q: np.ndarray, mean0: np.ndarray,
                  cov0: np.ndarray, observations: Observations, count: int
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Filtered and predicted moments of every state given exact observations of the leading
    ``count`` coordinates at some states ((index, target (K, count)) pairs, ascending).

    Returns filtered means (K, T, D), predicted means (K, T, D), filtered covariances
    (T, D, D) and predicted covariances (T, D, D) (state 0: predicted = N(mean0, cov0)).
    Between observed states the predictions come in one batch from :func:`prefix_compose`.
    """
    T, D = len(Phi) + 1, len(mean0)
    K = observations[0][1].shape[0] if observations else 1
    mf, mp = np.empty((K, T, D)), np.empty((K, T, D))
    Pf, Pp = np.empty((T, D, D)), np.empty((T, D, D))
    mp[:, 0], Pp[0] = mean0, cov0
    mf[:, 0], Pf[0] = mean0, cov0

    def advance(i: int, j: int, m: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        A, b, B = prefix_compose(Phi[i:j], u[i:j], Q[i:j])
        span = slice(i + 1, j + 1)
        mp[:, span] = np.einsum("sij,kj->ksi", A, m) + b
        Pp[span] = spread(A, P, B)
        mf[:, span], Pf[span] = mp[:, span], Pp[span]
        return mp[:, j].copy(), Pp[j].copy()

    _, filtered = _filter(mean0, cov0, observations, count, advance)
    for (index, _), (m, P) in zip(observations, filtered):
        mf[:, index], Pf[index] = m, P
    last = observations[-1][0] if observations else 0
    if last < T - 1:
        advance(last, T - 1, mf[:, last], Pf[last])
    return mf, mp, Pf, Pp


def rts_smooth(Phi: np.ndarray, mf: np.ndarray, mp: np.ndarray, Pf: np.ndarray,
               Pp: np.ndarray) -> np.ndarray:
    """Smoothed means (K, T, D) from the output of :func:`kalman_filter` (Rauch-Tung-Striebel):
    ms_i = mf_i + G_i (ms_{i+1} - mp_{i+1}), G_i = Pf_i Phi_i^T Pp_{i+1}^{-1} (gains batched,
    the backward pass a loop over the states)."""
    Pp_next = 0.5 * (Pp[1:] + np.swapaxes(Pp[1:], 1, 2))
    G = np.swapaxes(np.linalg.solve(Pp_next, Phi @ Pf[:-1]), 1, 2)   # (T-1, D, D)
    ms = mf.copy()
    for i in range(len(Phi) - 1, -1, -1):
        ms[:, i] += (ms[:, i + 1] - mp[:, i + 1]) @ G[i].T
    return ms


# ------------------------------------------------------------------------------ information form
def backward_messages(Phi: np.ndarray, u: np.ndarray, Q: np.ndarray, L_obs: np.ndarray,
                      e_obs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Information (L (T, D, D), e (T, D)) of the observations at states >= i given x_i.

    L_obs (T, D, D), e_obs (T, D): each state's own observation in information form (zero
    where unobserved): its likelihood is exp(-0.5 x' L_obs x + e_obs' x). Between two observed
    states a < j the message of x_i (a <= i < j) is the message of x_j carried back through
    the composed step x_j = A x_i + b + N(0, B) (:func:`suffix_compose`, log depth):
    L_i = A' (I + L_j B)^-1 L_j A, e_i = A' (I + L_j B)^-1 (e_j - L_j b); only the loop over
    the observed states is sequential (a zero message is not carried).
    """
    T, D = L_obs.shape[:2]
    L_msg, e_msg = L_obs.copy(), e_obs.copy()
    observed = np.flatnonzero(np.any(L_obs != 0.0, axis=(1, 2)))
    j = T - 1
    while j > 0:
        a = int(observed[observed < j].max(initial=0))
        if not (np.any(L_msg[j]) or np.any(e_msg[j])):   # nothing observed at or after j
            j = a
            continue
        A, b, B = suffix_compose(Phi[a:j], u[a:j], Q[a:j])
        L_j, e_j = L_msg[j], e_msg[j]
        rhs = np.broadcast_to(np.hstack([L_j, e_j[:, None]]), (j - a, D, D + 1))
        carried = np.linalg.solve(np.eye(D) + L_j @ B, rhs)           # (I + L_j B)^-1 [L_j, e_j]
        L_t, e_t = carried[..., :D], carried[..., D]
        L_t = 0.5 * (L_t + np.swapaxes(L_t, 1, 2))
        At = np.swapaxes(A, 1, 2)
        L_i = At @ L_t @ A
        L_msg[a:j] += 0.5 * (L_i + np.swapaxes(L_i, 1, 2))
        e_msg[a:j] += np.einsum("sij,sj->si", At, e_t - np.einsum("sij,sj->si", L_t, b))
        j = a
    return L_msg, e_msg


def conditioned_chain(Phi: np.ndarray, u: np.ndarray, Q: np.ndarray, mean0: np.ndarray,
                      cov0: np.ndarray, L_msg: np.ndarray, e_msg: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The chain conditioned on observations with backward messages (L_msg, e_msg)
    (:func:`backward_messages`): again a chain, (Phi', u', Q', mean0', cov0').

    With K_i = (Q_i^-1 + L_{i+1})^-1 = Q (I + L Q)^-1: Phi' = (I - K L) Phi,
    u' = (I - K L) u + K e, Q' = K (symmetrised); x_0 | y ~ N(m0 + K0 (e_0 - L_0 m0),
    (I - K0 L_0) P0) with K0 = P0 (I + L_0 P0)^-1.
    """
    D = len(mean0)
    eye = np.eye(D)
    L_next, e_next = L_msg[1:], e_msg[1:]
    Q_inv = np.linalg.inv(Q)
    gains = np.linalg.inv(0.5 * (Q_inv + np.swapaxes(Q_inv, 1, 2)) + L_next)
    L, e = L_msg[0], e_msg[0]
    keep = eye - gains @ L_next                                    # (T-1, D, D)
    Phi_c = keep @ Phi
    u_c = np.einsum("tij,tj->ti", keep, u) + np.einsum("tij,tj->ti", gains, e_next)
    Q_c = gains                                                    # (Q^-1 + L)^-1 = (I - K L) Q
    Q_c = 0.5 * (Q_c + np.swapaxes(Q_c, 1, 2))
    K0 = np.linalg.solve((eye + L @ cov0).T, cov0).T              # P0 (I + L P0)^-1
    m0 = mean0 + K0 @ (e - L @ mean0)
    P0 = (eye - K0 @ L) @ cov0
    return Phi_c, u_c, Q_c, m0, 0.5 * (P0 + P0.T)
