"""The fast solver: Levenberg-Marquardt on the (T, 2n) state array with a banded Cholesky.

Each iteration linearizes the problem once (:meth:`clamp.graph.problem.PlanningProblem.normal_equations`:
block-tridiagonal H, gradient g), then tries damped steps (H + lambda I) delta = g, solved by
LAPACK's banded Cholesky (:class:`DampedBandSolver`: lower storage, Jacobi-scaled so stiff and
soft states do not decide the pivots). A damped matrix that is not numerically
positive definite counts as a rejected trial (lambda grows), which is the fallback.

Workspace correction (second-order correction, on by default): the learned workspace prior is
extremely stiff (per-step noise down to micrometres) while x(theta) = [fk(q), J(q) qdot] is
curved in theta, so a joint step of s rad leaves the linear model's prediction by ~s^2 x arm
length and plain LM only accepts tiny steps (hundreds of iterations). Each trial point is moved
back onto the workspace states the linear model predicts, x_pred = x(theta) + dx/dtheta delta,
by ``workspace_correction`` per-state minimum-norm chord updates (:class:`WorkspaceCorrection`;
the free joint directions keep the LM step). A trial is accepted only if the true error decreases.

Damping: the gain ratio rho = actual / predicted decrease sets lambda *= max(1/3,
1 - (2 rho - 1)^3) after an accepted step; a rejected one multiplies lambda by 2, 4, 8, ...
Stopping (units: the graph error is a negative log posterior in nats): a step is small when
it decreases the error by at most ``absolute_tol`` nats or by at most ``relative_tol`` times the
error. The solver stops after ``patience`` consecutive small accepted steps; or when no damping
up to ``lambda_max`` decreases the error; or after ``max_iterations`` accepted steps. From a
warm start (:class:`WarmStart`, e.g. replanning from a previous plan near the new optimum) the
damping starts at ``WarmStart.lambda_initial``, ``absolute_tol`` is ``WarmStart.tolerance``
nats, one small step stops (patience 1), and so does a linear model predicting a decrease of at
most ``WarmStart.tolerance`` nats for the next trial step (that step is then not taken: no
workspace correction, no error evaluation).

Every step runs with one BLAS thread (threadpoolctl): the products are small (d <= 14) and a
threaded BLAS only adds synchronisation (measured slower under load).
"""
from __future__ import annotations

import logging
from collections.abc import Callable
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.linalg.lapack import dpbtrf, dpbtrs

from clamp.optim.banded import band_layout
from clamp.factors.hand_orientation import chain_states
from clamp.graph.problem import NormalEquations, PlanningProblem
from skillplan.threads import single_blas_thread

log = logging.getLogger(__name__)

#: the stop reason of a solve its ``halt`` callback stopped (e.g. a deadline)
HALTED = "halted"


@dataclass(frozen=True)
class WarmStart:
    """Solver settings for a start near the optimum (see the module docstring).

    lambda_initial: first damping (the Jacobi-scaled system has unit diagonal; replanning
    box_closing, 1e-3 to 1 all take one step after a 5 cm goal move, while a 5 cm obstacle
    move took 4 steps from 0.1 or 1 and 6 from 0.01); tolerance [nats]: the absolute stopping
    tolerance (0.1 nats: a posterior density ratio of 1.1; the replans then end within 0.1 mm
    of the fresh plans' paths, see benchmarks/bench_replan.py).
    """

    lambda_initial: float = 0.1
    tolerance: float = 0.1


@dataclass(frozen=True)
class SolverOutcome:
    """Optimised joint states theta (T, 2n), accepted iterations, graph error before and after,
    solved trial steps (accepted or rejected), why it stopped and seconds per phase
    ("linearize", "solve", "correction", "error")."""

    theta: np.ndarray
    iterations: int
    initial_error: float
    final_error: float
    trials: int
    stop_reason: str
    timings: dict[str, float] = field(default_factory=dict)


class DampedBandSolver:
    """Solves (H + lambda I) delta = g for many lambda, H symmetric positive semi-definite in
    LAPACK lower band storage (w, N) (H[r, c] at band[r - c, c]), g (N,); rows (w, N) the row
    index of every band entry (:attr:`clamp.optim.banded.BandLayout.rows`).

    The system is scaled to unit diagonal once (Jacobi, S = diag(H)^-1/2): the scaled matrix
    S H S + lambda S^2 keeps stiff and soft states from deciding the pivots; each lambda then
    costs one copy, one banded Cholesky (LAPACK dpbtrf) and two triangular solves (dpbtrs).
    """

    def __init__(self, band: np.ndarray, gradient: np.ndarray, rows: np.ndarray):
        diagonal = band[0]
        self.finite = bool(np.all(np.isfinite(band)) and np.all(np.isfinite(gradient)))
        positive = np.where(diagonal > 0.0, diagonal, 1.0)
        self.scale = 1.0 / np.sqrt(positive)
        self.scaled = band * self.scale[rows] * self.scale[None, :]
        self.rhs = self.scale * gradient
        self.damping_weights = self.scale ** 2

    def solve(self, lam: float) -> np.ndarray | None:
        """delta (N,), or None when H + lam I is not numerically positive definite."""
        if not self.finite:
            return None
        damped = self.scaled.copy()
        damped[0] += lam * self.damping_weights
        factor, info = dpbtrf(damped, lower=1, overwrite_ab=1)
        if info != 0:
            return None
        y, info = dpbtrs(factor, self.rhs, lower=1)
        delta = self.scale * y
        return delta if info == 0 and np.all(np.isfinite(delta)) else None


class WorkspaceCorrection:
    """Moves trial points back onto the workspace states the linear model predicts.

    At a linearization point with workspace states x (T, 6) and Jacobian J = dx/dtheta
    (T, 6, 2n), a step delta predicts x + J delta. :meth:`apply` takes the trial point
    theta + delta through at most ``iterations`` per-state Gauss-Newton updates
    theta += J(theta)^T (J(theta) J(theta)^T + damping I)^-1 (x_pred - x(theta)) (minimum
    norm; damping [m^2] keeps singular arms finite), stopping once every workspace residual is
    below ``tolerance`` [m, m/s] (1e-8: 1 % of the stiffest learned noise, ~1e-6 m; the plans
    equal those of always two updates). Fresh Jacobians matter: the chord variant (the
    linearization point's J) needs ~30 % more LM iterations on box_closing. The kinematics of
    the returned point are those of its last window, which the error evaluation then reuses.
    """

    def __init__(self, window_of, x: np.ndarray, jacobian: np.ndarray, iterations: int,
                 damping: float = 1e-9, tolerance: float = 1e-8,
                 rotations: np.ndarray | None = None):
        self.window_of = window_of
        self.rotations = rotations
        if rotations is not None:           # the hand's rotation too (a pose prior's chain)
            z, dz = chain_states(window_of(None), rotations, True)
            x, jacobian = np.concatenate([x, z], axis=1), np.concatenate([jacobian, dz], axis=1)
        self.x, self.jacobian = x, jacobian
        self.iterations = iterations
        self.damping = damping * np.eye(x.shape[1])
        self.tolerance = tolerance

    def states(self, theta: np.ndarray, jacobians: bool = True
               ) -> tuple[np.ndarray, np.ndarray | None]:
        """The corrected states at theta (T, 2n) and their Jacobian: the workspace states,
        with ``rotations`` (a stiff orientation chain's mean rotations (T, 3, 3)) also the
        orientation states that chain reads (:func:`clamp.factors.hand_orientation.chain_states`);
        without ``jacobians`` the orientation states' Jacobian is not computed (None: the
        states of a point that is not updated further)."""
        window = self.window_of(theta)
        x, jac = window.workspace()
        if self.rotations is None:
            return x, jac
        z, dz = chain_states(window, self.rotations, jacobians)
        if not jacobians:
            return np.concatenate([x, z], axis=1), None
        return np.concatenate([x, z], axis=1), np.concatenate([jac, dz], axis=1)

    def apply(self, theta: np.ndarray, delta: np.ndarray) -> np.ndarray:
        """The corrected trial point (T, 2n) for the step delta (T, 2n) (theta + delta moved)."""
        target = self.x + np.einsum("tij,tj->ti", self.jacobian, delta)
        out = theta + delta
        for k in range(self.iterations + 1):
            x, jac = self.states(out, jacobians=k < self.iterations)
            residual = target - x
            if k == self.iterations or np.max(np.abs(residual)) <= self.tolerance:
                break
            out = self.update(out, jac, residual)
        return out

    def update(self, theta: np.ndarray, jacobian: np.ndarray, residual: np.ndarray) -> np.ndarray:
        """One per-state update of theta (K, 2n) with workspace Jacobian (K, 6, 2n) towards
        workspace states ``residual`` (K, 6) [m, m/s] away: theta + J^T (J J^T + damping I)^-1
        residual."""
        gram = jacobian @ np.swapaxes(jacobian, 1, 2) + self.damping
        step = np.linalg.solve(gram, residual[..., None])[..., 0]
        return theta + np.einsum("tji,tj->ti", jacobian, step)


def levenberg_marquardt(problem: PlanningProblem, theta0: np.ndarray, *,
                        lambda_initial: float = 0.1, lambda_max: float = 1e10,
                        max_iterations: int = 500, relative_tol: float = 1e-3,
                        absolute_tol: float = 1e-2, patience: int = 2,
                        workspace_correction: int = 2,
                        warm_start: WarmStart | None = None,
                        halt: Callable[[], bool] | None = None) -> SolverOutcome:
    """Minimise the problem's graph error from theta0 (T, 2n) (see the module docstring);
    ``warm_start`` replaces ``lambda_initial``, ``absolute_tol`` and ``patience`` by the
    warm-start rule; ``halt()``, checked before every iteration, stops the solve where it is
    (stop reason "halted": e.g. a deadline)."""
    predicted_tol = -np.inf
    if warm_start is not None:
        lambda_initial, absolute_tol = warm_start.lambda_initial, warm_start.tolerance
        patience, predicted_tol = 1, warm_start.tolerance
    with single_blas_thread():
        return _levenberg_marquardt(problem, np.array(theta0, dtype=float), lambda_initial,
                                    lambda_max, max_iterations, relative_tol, absolute_tol,
                                    patience, workspace_correction, predicted_tol, halt)


def _levenberg_marquardt(problem: PlanningProblem, theta: np.ndarray, lam: float,
                         lambda_max: float, max_iterations: int, relative_tol: float,
                         absolute_tol: float, patience: int, correction: int,
                         predicted_tol: float, halt: Callable[[], bool] | None = None
                         ) -> SolverOutcome:
    T, d = problem.num_states, problem.dim
    layout = band_layout(T, d)
    timings = dict.fromkeys(("linearize", "solve", "correction", "error"), 0.0)
    clock = time.perf_counter()

    def lap(phase: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        timings[phase] += now - clock
        clock = now

    error = initial_error = problem.error(theta)
    lap("error")
    iterations = trials = small_steps = 0
    growth = 2.0
    stop = "max_iterations"
    while iterations < max_iterations:
        if error <= 0.0:
            stop = "zero_error"
            break
        if halt is not None and halt():
            stop = HALTED
            break
        system: NormalEquations = problem.normal_equations(theta)
        g = system.g.reshape(-1)
        solver = DampedBandSolver(layout.band(system.D, system.E), g, layout.rows)
        corrector = None
        if correction:
            window = problem.window(theta)
            rotations = problem.rotation_reference
            corrector = WorkspaceCorrection(
                lambda at: window if at is None else problem.window(at), *window.workspace(),
                correction, rotations=rotations)
        lap("linearize")
        accepted = model_converged = False
        trials_here = 0
        while lam <= lambda_max:
            trials += 1
            step = solver.solve(lam)
            lap("solve")
            if step is None:
                lam *= growth
                growth *= 2.0
                continue
            if trials_here == 0 and _predicted_decrease(step, g, lam) <= predicted_tol:
                model_converged = True
                break
            trials_here += 1
            delta = step.reshape(T, d)
            if corrector is not None:
                candidate = corrector.apply(theta, delta)
                lap("correction")
            else:
                candidate = theta + delta
            new_error = problem.error(candidate, bound=error)
            lap("error")
            if np.isfinite(new_error) and new_error < error:
                accepted = True
                break
            lam *= growth
            growth *= 2.0
        if not accepted:
            # no step decreases the error: converged when the model predicts nothing or the
            # last accepted step was already below the tolerances (at the optimum, rounding)
            stop = "converged" if model_converged or small_steps else "no_decrease"
            break
        iterations += 1
        decrease = error - new_error
        small = decrease <= absolute_tol or decrease <= relative_tol * error
        small_steps = small_steps + 1 if small else 0
        predicted = _predicted_decrease(step, g, lam)
        rho = decrease / predicted if predicted > 0.0 else 0.0
        log.debug("iteration %d: error %.6g -> %.6g (predicted decrease %.3g), lambda %.3g, "
                  "%d trials", iterations, error, new_error, predicted, lam, trials)
        lam *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
        growth = 2.0
        theta, error = candidate, new_error
        if small_steps >= patience:
            stop = "converged"
            break
    return SolverOutcome(theta, iterations, initial_error, error, trials, stop, timings)


def _predicted_decrease(step: np.ndarray, g: np.ndarray, lam: float) -> float:
    """Decrease of 0.5 ||A d - b||^2 the linear model predicts for the step d (N,) solving
    (H + lam I) d = g: 0.5 (d.g + lam d.d) [nats]."""
    return 0.5 * float(step @ g + lam * step @ step)
