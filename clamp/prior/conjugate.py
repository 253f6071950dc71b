"""Incremental Bayesian learning of the prior's transitions (the reference's conjugate model).

Per step i -> i+1 and per state group g (an axis's ``[p_d, v_d]``, or the whole state when
coupled) the regression y = M [x; 1] (x the group's state at step i, k values; y the same at
step i+1) has a matrix-normal / inverse-Wishart prior with M0 = 0, K0 = 1e-10 I,
S0 = N0 I, N0 = 1e-10. A batch of demonstrations with weights W updates

    Sxx = X W X' + K,  Syx = Y W X' + M K,  Syy = Y W Y' + M K M',
    M <- Syx Sxx^-1,  K <- Sxx,  S <- S + Syy - Syx Sxx^-1 Syx',  N <- N + sum(W)

(the previous S, which is S0 at the first update, so that any order and any split of the
demonstrations gives the batch posterior). The noise given to the prior is the inverse-Wishart
mode S / (N + k + 1). Numerically the posterior is carried as the triangular factor R of the
weighted data ``[x', 1, y']`` stacked under the prior's rows (R' R = [[Sxx, Sxy], [Syx, Syy]]),
updated by QR: no normal equations, no cancellation in S, M from a triangular solve.
The first states' weighted mean and scatter are merged by Chan's pairwise formula.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from clamp.errors import ShapeError

#: the reference's prior: M0 = 0, K0 = K0_SCALE I, S0 = N0 I, N0 = N0_SCALE
K0_SCALE = 1e-10
N0_SCALE = 1e-10
#: entries of a prior file that hold the posterior (prefixed ``posterior_``)
POSTERIOR_KEYS = ("M", "K", "S", "N", "factor", "groups", "first_weight", "first_mean",
                  "first_scatter")


@dataclass(frozen=True)
class ConjugatePosterior:
    """Posterior of every step's regression, with the first states' running statistics.

    groups (G, k) state indices regressed jointly; factor (T-1, G, 2k+1, 2k+1) triangular R;
    N (T-1,) posterior degrees of freedom; first_weight float, first_mean (D,), first_scatter
    (D, D) weighted count, mean and centred scatter of the first states (m, m/s).
    """

    groups: np.ndarray
    factor: np.ndarray
    N: np.ndarray
    first_weight: float
    first_mean: np.ndarray
    first_scatter: np.ndarray

    @classmethod
    def empty(cls, steps: int, size: int, groups: np.ndarray) -> ConjugatePosterior:
        """The prior (M0, K0, S0, N0) for ``steps`` transitions of a state of ``size``."""
        G, k = groups.shape
        factor = np.zeros((steps, G, 2 * k + 1, 2 * k + 1))
        diag = np.arange(k + 1)
        factor[:, :, diag, diag] = np.sqrt(K0_SCALE)
        return cls(np.asarray(groups), factor, np.full(steps, N0_SCALE), 0.0, np.zeros(size),
                   np.zeros((size, size)))

    @property
    def k(self) -> int:
        """Size of one regressed state group."""
        return int(self.groups.shape[1])

    def update(self, states: np.ndarray, weights: np.ndarray | None = None) -> ConjugatePosterior:
        """Posterior after demonstrations states (M, T, D) with sample weights (M, T-1) of the
        transitions (None: all 1) and (M, T) per state for the first one (column 0 used)."""
        M, T, D = states.shape
        if T - 1 != len(self.factor) or D != len(self.first_mean):
            raise ShapeError(f"demonstrations: expected {len(self.factor) + 1} steps of "
                             f"{len(self.first_mean)} values like the prior, got (M, T, D) = "
                             f"{states.shape} (resample them to the prior's steps)")
        w = np.ones((M, T)) if weights is None else np.asarray(weights, dtype=float)
        step_w = np.minimum(w[:, :-1], w[:, 1:])                       # (M, T-1)
        k = self.k
        # rows sqrt(w) [x', 1, y'] of every demonstration: (T-1, G, M, 2k+1)
        x = np.moveaxis(states[:, :-1][:, :, self.groups], 0, 2)
        y = np.moveaxis(states[:, 1:][:, :, self.groups], 0, 2)
        rows = np.concatenate([x, np.ones(x.shape[:-1] + (1,)), y], axis=-1)
        rows *= np.sqrt(step_w.T)[:, None, :, None]
        stacked = np.concatenate([self.factor, rows], axis=2)
        factor = np.linalg.qr(stacked, mode="r")[..., : 2 * k + 1, :]
        weight0, mean0, scatter0 = _merge_moments(self.first_weight, self.first_mean,
                                                  self.first_scatter, states[:, 0], w[:, 0])
        return ConjugatePosterior(self.groups, factor, self.N + step_w.sum(axis=0), weight0,
                                  mean0, scatter0)

    # ------------------------------------------------------------------ the reference's view
    @property
    def M(self) -> np.ndarray:
        """Posterior mean (T-1, G, k, k+1) of every regression y = M [x; 1]."""
        k = self.k
        Rxx, Rxy = self.factor[..., : k + 1, : k + 1], self.factor[..., : k + 1, k + 1:]
        return np.swapaxes(np.linalg.solve(Rxx, Rxy), -1, -2)

    @property
    def K(self) -> np.ndarray:
        """Posterior column precision Sxx (T-1, G, k+1, k+1)."""
        Rxx = self.factor[..., : self.k + 1, : self.k + 1]
        return np.swapaxes(Rxx, -1, -2) @ Rxx

    @property
    def S(self) -> np.ndarray:
        """Posterior inverse-Wishart scale (T-1, G, k, k): residual scatter plus S0."""
        Ryy = self.factor[..., self.k + 1:, self.k + 1:]
        return np.swapaxes(Ryy, -1, -2) @ Ryy + N0_SCALE * np.eye(self.k)

    def transitions(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per-group Phi (T-1, G, k, k), u (T-1, G, k) and MAP noise S / (N + k + 1)."""
        M = self.M
        Q = self.S / (self.N + self.k + 1.0)[:, None, None, None]
        return M[..., :-1], M[..., -1], Q

    def next_variance(self) -> np.ndarray:
        """Weighted variance (T-1, G, k) of every step's next states y over the demonstrations,
        from the factor's moments (R' R holds sum w, sum w y and sum w y y')."""
        k = self.k
        ones = self.factor[..., :, k]                                  # (T-1, G, 2k+1)
        ys = self.factor[..., :, k + 1:]                               # (T-1, G, 2k+1, k)
        count = np.einsum("...r,...r->...", ones, ones)
        total = np.einsum("...r,...rj->...j", ones, ys)
        square = np.einsum("...rj,...rj->...j", ys, ys)
        count = np.maximum(count, 1e-300)[..., None]
        return np.maximum(square / count - (total / count) ** 2, 0.0)

    def initial(self) -> tuple[np.ndarray, np.ndarray]:
        """Weighted mean (D,) and biased covariance (D, D) of the first states."""
        return self.first_mean, self.first_scatter / max(self.first_weight, 1e-300)

    # ------------------------------------------------------------------ persistence
    def arrays(self) -> dict[str, np.ndarray]:
        """Every array of the posterior (the reference's M, K, S, N and our factor)."""
        return {"M": self.M, "K": self.K, "S": self.S, "N": self.N, "factor": self.factor,
                "groups": self.groups, "first_weight": np.array(self.first_weight),
                "first_mean": self.first_mean, "first_scatter": self.first_scatter}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> ConjugatePosterior:
        """Inverse of :meth:`arrays` (the factor carries the posterior; M, K, S are views)."""
        return cls(np.asarray(arrays["groups"], dtype=np.intp),
                   np.asarray(arrays["factor"], dtype=float), np.asarray(arrays["N"], dtype=float),
                   float(arrays["first_weight"]), np.asarray(arrays["first_mean"], dtype=float),
                   np.asarray(arrays["first_scatter"], dtype=float))


def _merge_moments(weight: float, mean: np.ndarray, scatter: np.ndarray, x: np.ndarray,
                   w: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Chan's pairwise merge of (weight, mean, centred scatter) with weighted samples x (M, D)."""
    wb = float(w.sum())
    if wb <= 0.0:
        return weight, mean, scatter
    mean_b = w @ x / wb
    centred = x - mean_b
    scatter_b = (centred * w[:, None]).T @ centred
    total = weight + wb
    delta = mean_b - mean
    return (total, mean + delta * (wb / total),
            scatter + scatter_b + np.outer(delta, delta) * (weight * wb / total))
