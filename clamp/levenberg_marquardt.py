"""A lean Levenberg-Marquardt loop on GTSAM's linearization and sparse linear solver.

GTSAM's own LevenbergMarquardtOptimizer is the reference; this loop follows the same rules
(damping lambda I added to the Gauss-Newton system; lambda / 10 after an accepted step,
x 10 after a rejected or unsolvable one; stop at lambda_upper_bound, max_iterations or when
the absolute or relative error decrease falls below its tolerance) but reuses one chain
ordering and one set of damping factors per lambda, which is several times cheaper per
iteration than the generic optimizer for the planner's chain-structured graphs.

Optional extensions (off by default, so the plain loop reproduces GTSAM's rules):
``correction(values, delta, candidate) -> Values`` maps every trial point values + delta to
the point actually evaluated (a second-order correction that restores stiff, curved
constraints the linear model keeps only to first order; see
:mod:`clamp.workspace_correction`), and ``solver="qr"`` eliminates with Householder QR instead
of Cholesky, which works on the square-root system and so stays solvable at the small damping
that ill-conditioned graphs (weights ~1e12 next to ~1) need (GTSAM's Cholesky declares such
systems indeterminate), ``solver="banded"`` solves the damped normal equations
(H + lambda I) delta = g with LAPACK's banded Cholesky after scaling H to unit diagonal, when
the system provides them as a band (``system.normal_equations(values) -> (band, g)`` in the
order of ``system.keys``, e.g. :meth:`clamp.vectorized_graph.VectorizedGraph.normal_equations`;
chain graphs are block-tridiagonal): H is formed once per linearization and every trial
costs one banded factorization instead of a GTSAM elimination with a fresh set of damping
factors (several times cheaper; same steps to ~1e-10 in the model error); when the system
has no band or the scaled matrix is not numerically positive definite, that trial uses QR, and
``damping_update="gain_ratio"`` adapts lambda to the gain ratio rho = actual / predicted error
decrease (Nielsen's rule: lambda *= max(1/3, 1 - (2 rho - 1)^3) after an accepted step,
lambda *= nu, nu *= 2 after a rejected one) instead of the fixed factor 10, so an accurate
linear model (rho ~ 1) lowers the damping quickly and a poor one raises it gently.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
import time
from dataclasses import dataclass, field
from typing import Protocol

import gtsam
import numpy as np
import scipy.linalg


@dataclass
class LMOutcome:
    """Optimised values, number of accepted iterations, initial and final graph error, number
    of solved (accepted or rejected) trial steps and the seconds spent in each phase
    ("linearize", "solve" (incl. damping), "correction", "error")."""

    values: gtsam.Values
    iterations: int
    initial_error: float
    final_error: float
    trials: int
    timings: dict[str, float] = field(default_factory=dict)


Correction = Callable[[gtsam.Values, gtsam.VectorValues, gtsam.Values], gtsam.Values]


class GraphSystem(Protocol):
    """What the loop needs of a graph: its error and (whitened) linearization at values."""

    def error(self, values: gtsam.Values) -> float: ...

    def linearize(self, values: gtsam.Values) -> gtsam.GaussianFactorGraph: ...


def solve_banded_damped(band: np.ndarray, gradient: np.ndarray,
                        damping: np.ndarray) -> np.ndarray | None:
    """delta (N,) solving (H + diag(damping)) delta = gradient, H symmetric in LAPACK lower
    band storage (w + 1, N) (H[r, c] at [r - c, c], r >= c); None when the damped matrix is not
    numerically positive definite.

    The matrix is scaled to unit diagonal first (Jacobi: S (H + D) S y = S g, delta = S y),
    so entries of very different magnitude (stiff and soft states) do not decide the pivots.
    (Lower storage: LAPACK's unblocked banded Cholesky then updates contiguous columns, ~3x
    faster than upper storage with a multithreaded BLAS.)
    """
    damped = band.copy()
    damped[0] += damping
    diagonal = damped[0]
    if not np.all(np.isfinite(damped)) or np.any(diagonal <= 0.0):
        return None
    scale = 1.0 / np.sqrt(diagonal)
    N = band.shape[1]
    rows = np.minimum(np.arange(N)[None, :] + np.arange(band.shape[0])[:, None], N - 1)
    damped *= scale[rows]
    damped *= scale[None, :]
    try:
        factor = scipy.linalg.cholesky_banded(damped, lower=True, check_finite=False)
    except np.linalg.LinAlgError:
        return None
    delta = scale * scipy.linalg.cho_solve_banded((factor, True), scale * gradient,
                                                  check_finite=False)
    return delta if np.all(np.isfinite(delta)) else None


def _vector_values(delta: np.ndarray, keys: Sequence[int], offsets: np.ndarray) -> gtsam.VectorValues:
    """GTSAM VectorValues holding delta[offsets[i]:offsets[i+1]] under keys[i]."""
    out = gtsam.VectorValues()
    for key, a, b in zip(keys, offsets[:-1], offsets[1:]):
        out.insert(key, delta[a:b])
    return out


SOLVERS = ("cholesky", "qr", "banded")
DAMPING_UPDATES = ("gtsam", "gain_ratio")


def chain_ordering(keys: Sequence[int]) -> gtsam.Ordering:
    """Elimination ordering that follows the keys (optimal fill-in for a chain)."""
    ordering = gtsam.Ordering()
    for key in keys:
        ordering.push_back(key)
    return ordering


def jacobian_diagonal(linear: gtsam.GaussianFactorGraph, keys: Sequence[int],
                      dims: Sequence[int], position: dict[int, int],
                      offsets: np.ndarray) -> np.ndarray:
    """diag(J^T J) (sum(dims),) of a whitened linear graph, in the order of ``keys``."""
    rows, cols, entries = linear.sparseJacobian_()
    present = sorted(linear.keys())  # GTSAM's column order: sorted keys
    starts = np.concatenate([[0], np.cumsum([dims[position[k]] for k in present])])
    cols = cols.astype(int) - 1
    inside = cols < starts[-1]  # the last column is b
    column_sums = np.bincount(cols[inside], weights=entries[inside] ** 2, minlength=starts[-1])
    if present == list(keys):
        return column_sums
    out = np.zeros(offsets[-1])
    for k, a, b in zip(present, starts[:-1], starts[1:]):
        out[offsets[position[k]]:offsets[position[k]] + (b - a)] = column_sums[a:b]
    return out


def levenberg_marquardt(graph: gtsam.NonlinearFactorGraph, initial: gtsam.Values,
                        keys: Sequence[int], dims: Sequence[int], lambda_initial: float = 1e3,
                        lambda_upper_bound: float = 1e10, max_iterations: int = 500,
                        relative_error_tol: float = 1e-5, absolute_error_tol: float = 1e-5,
                        correction: Correction | None = None, solver: str = "cholesky",
                        damping_update: str = "gtsam", patience: int = 1,
                        system: GraphSystem | None = None,
                        diagonal_damping: bool = False) -> LMOutcome:
    """Minimise ``graph`` from ``initial`` over the variables ``keys`` of sizes ``dims``.

    correction: optional map of a trial point (see the module docstring); solver "cholesky"
    (GTSAM's default) or "qr"; damping_update "gtsam" (x 10 / 10) or "gain_ratio"; patience:
    stop once that many consecutive accepted steps decreased the error by less than the
    tolerances (GTSAM: 1; more tolerates a single small step on a non-monotone descent);
    system: an object evaluating and linearizing ``graph`` faster with the same results
    (e.g. :class:`clamp.vectorized_graph.VectorizedGraph`; if it has ``error_below(values,
    bound)``, trial points are evaluated with it: only whether the error is below the current
    one matters for a rejected trial); default the graph itself;
    diagonal_damping: damp with lambda diag(J^T J) (GTSAM's diagonalDamping, entries clamped to
    [1e-6, 1e32]) instead of lambda I (see the module docstring).
    """
    if int(patience) < 1:
        raise ValueError(f"patience: expected an integer >= 1, got {patience!r}")
    if solver not in SOLVERS:
        raise ValueError(f"solver: unknown {solver!r}; valid: {', '.join(SOLVERS)}")
    if damping_update not in DAMPING_UPDATES:
        raise ValueError(f"damping_update: unknown {damping_update!r}; "
                         f"valid: {', '.join(DAMPING_UPDATES)}")
    gain_ratio = damping_update == "gain_ratio"
    ordering = chain_ordering(keys)
    damping_cache: dict[float, list[gtsam.JacobianFactor]] = {}

    units = {d: (np.eye(d), np.zeros(d), gtsam.noiseModel.Unit.Create(d)) for d in set(dims)}

    def damping(lam: float) -> list[gtsam.JacobianFactor]:
        if lam not in damping_cache:
            if len(damping_cache) > 8:  # the gain-ratio rule rarely repeats a lambda
                damping_cache.clear()
            s = np.sqrt(lam)
            scaled = {d: s * eye for d, (eye, _, _) in units.items()}
            damping_cache[lam] = [gtsam.JacobianFactor(k, scaled[d], units[d][1], units[d][2])
                                  for k, d in zip(keys, dims)]
        return damping_cache[lam]

    system = graph if system is None else system
    error_below = getattr(system, "error_below", None)  # optional early-exit evaluation
    offsets = np.concatenate([[0], np.cumsum(dims)])
    position = {k: i for i, k in enumerate(keys)}

    def scaled_damping(lam: float, diagonal: np.ndarray) -> list[gtsam.JacobianFactor]:
        return [gtsam.JacobianFactor(k, np.diag(np.sqrt(lam * diagonal[a:b])), units[d][1],
                                     units[d][2])
                for k, d, a, b in zip(keys, dims, offsets[:-1], offsets[1:])]

    timings = dict.fromkeys(("linearize", "solve", "correction", "error"), 0.0)
    clock = time.perf_counter()

    def lap(phase: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        timings[phase] += now - clock
        clock = now

    values = initial
    error = initial_error = float(system.error(values))
    lap("error")
    lam = float(lambda_initial)
    iterations = trials = 0
    growth = 2.0 if gain_ratio else 10.0  # lambda factor after a rejected step
    small_steps = 0
    normal_equations = getattr(system, "normal_equations", None) if solver == "banded" else None
    if normal_equations is not None and list(getattr(system, "keys", ())) != list(keys):
        normal_equations = None  # the system's band follows its own key order
    while iterations < max_iterations and error > 0.0:
        banded = normal_equations(values) if normal_equations is not None else None
        linear = None if banded is not None else system.linearize(values)
        if diagonal_damping:
            diagonal = np.clip(banded[0][0] if banded is not None else
                               jacobian_diagonal(linear, keys, dims, position, offsets),
                               1e-6, 1e32)
        lap("linearize")
        accepted = False
        while lam <= lambda_upper_bound:
            trials += 1
            step = None
            if banded is not None:
                weights = diagonal if diagonal_damping else 1.0
                step = solve_banded_damped(banded[0], banded[1], lam * weights + np.zeros(offsets[-1]))
                if step is not None:
                    delta = _vector_values(step, keys, offsets)
                    # 0.5 ||A d - b||^2 decreases by g.d - 0.5 d.H.d, and (H + lam W) d = g
                    predicted = 0.5 * float(step @ banded[1] + lam * step @ (weights * step))
            if step is None:  # QR / Cholesky on GTSAM's linearization
                if linear is None:  # the banded normal equations are not positive definite
                    linear = system.linearize(values)
                damped = linear.clone()
                for factor in (scaled_damping(lam, diagonal) if diagonal_damping
                               else damping(lam)):
                    damped.push_back(factor)
                try:
                    delta = (damped.optimize(ordering, gtsam.EliminateQR)
                             if solver in ("qr", "banded") else damped.optimize(ordering))
                except RuntimeError:  # indeterminate system: damp more
                    lam *= 10.0
                    lap("solve")
                    continue
                predicted = None
            candidate = values.retract(delta)
            lap("solve")
            if correction is not None:
                candidate = correction(values, delta, candidate)
                lap("correction")
            new_error = float(error_below(candidate, error) if error_below is not None
                              else system.error(candidate))
            lap("error")
            if np.isfinite(new_error) and new_error < error:
                accepted = True
                break
            lam *= growth
            if gain_ratio:
                growth *= 2.0
        if not accepted:
            break
        iterations += 1
        decrease = error - new_error
        small = decrease <= absolute_error_tol or decrease <= relative_error_tol * error
        small_steps = small_steps + 1 if small else 0
        converged = small_steps >= patience
        if gain_ratio:
            if predicted is None:
                predicted = error - float(linear.error(delta))
            rho = decrease / predicted if predicted > 0.0 else 0.0
            lam *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
            growth = 2.0
        else:
            lam /= 10.0
        values, error = candidate, new_error
        if converged:
            break
    return LMOutcome(values, iterations, initial_error, error, trials, timings)
