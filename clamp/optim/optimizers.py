"""The optimizers a planning problem can be solved with, in one place.

:data:`clamp.config.OPTIMIZERS`: "fast" (:func:`clamp.optim.solver.levenberg_marquardt` on the state array) and
GTSAM's Levenberg-Marquardt, Dogleg and Gauss-Newton on ``problem.graph()``. Adding or swapping
an optimizer touches this file and its name in clamp.config. GTSAM runs its own loop (``optimize()``: its iterations,
its convergence rule); its iteration hook logs each iteration (debug level) and advances a
progress bar (:mod:`skillplan.progress`, drawn when an optimisation lasts more than
:data:`PROGRESS_DELAY` seconds).

Two settings matter on the planner's stiff, curved graphs (benchmarks/bench_gtsam_parity.py):

- Levenberg-Marquardt uses GTSAM's adaptive damping (``useFixedLambdaFactor = False``: lambda
  scaled by the gain ratio, Nielsen's rule) instead of its default fixed factor 10, which
  rejects many more trials and crawls;
- every linearization runs without copying the optimizer's Values. pybind11 hands a Python
  ``CustomFactor`` the C++ ``const Values&`` by copy (O(variables) per factor call) unless a
  Python object already wraps that very C++ object, in which case it passes that object.
  ``optimizer.values()`` returns such a wrapper of the optimizer's current Values, so
  :class:`_CurrentValues` holds one, renewed after every iteration: every factor of a
  linearization then gets the same object. (The trial Values GTSAM builds inside an iteration
  to compute its error have no wrapper and are still copied per call.) An error function may
  use the Values it is handed during the call only, as in GTSAM's C++ API.
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import gtsam
import numpy as np

from clamp.config import PlannerConfig, as_config
from clamp.errors import ClampTypeError
from clamp.graph.keys import values_to_states
from clamp.graph.problem import PlanningProblem
from clamp.optim.solver import WarmStart, levenberg_marquardt
from skillplan.validation import as_instance
from skillplan.progress import progress

log = logging.getLogger(__name__)

#: valid ``PlannerConfig.optimizer.optimizer`` names
#: seconds a GTSAM optimisation runs before its progress bar is drawn
PROGRESS_DELAY = 2.0
#: Levenberg-Marquardt gives up when no damping up to this decreases the error
LAMBDA_UPPER_BOUND = 1e10

IterationHook = Callable[[int, float, float], None]


def gtsam_params(config: PlannerConfig):
    """GTSAM's parameters for ``config`` and the optimizer class they are for: what
    ``optimize`` runs on ``problem.graph()``, for a caller who runs GTSAM by hand
    (``make(problem.graph(), problem.values(), params)``; docs/concepts.md#gtsams-optimizers).
    The stopping rule is the fast solver's (``OptimizerConfig.stopping``, by default 1e-3
    relative and 1e-2 nats absolute tolerances, :mod:`clamp.optim.stopping`): with them GTSAM's Levenberg-Marquardt ends within 0.3 mm
    of the fast plan on box_closing; tighter, it goes on towards the graph's optimum, which
    with the box lies 2 mm from the plan (benchmarks/bench_gtsam_parity.py, Table 0)."""
    opt, rule = config.optimizer, config.optimizer.stopping_rule()
    if opt.optimizer == "gtsam":
        params = gtsam.LevenbergMarquardtParams()
        params.setlambdaInitial(rule.lambda_initial)
        params.setlambdaUpperBound(LAMBDA_UPPER_BOUND)
        params.setUseFixedLambdaFactor(False)
        # lambda * I, not lambda * diag(H) (Marquardt's scaling): scaled by the stiff learned
        # prior's diagonal the first step barely moves and LM stops at once (box_closing with
        # the box: one iteration, 82 mm from the plan)
        params.setDiagonalDamping(False)
        make = gtsam.LevenbergMarquardtOptimizer
    elif opt.optimizer == "gtsam_dogleg":
        params, make = gtsam.DoglegParams(), gtsam.DoglegOptimizer
    else:
        params, make = gtsam.GaussNewtonParams(), gtsam.GaussNewtonOptimizer
    # QR: the stiff learned prior makes the normal equations too ill-conditioned for Cholesky
    # (undamped: GTSAM reports an indeterminate system; damped: LM stalls ~20 % above the
    # optimum of an empty scene). COLAMD's ordering of the chain costs < 1 ms.
    params.setLinearSolverType("MULTIFRONTAL_QR")
    params.setOrderingType("COLAMD")      # METIS: the same steps, no faster on the chain
    params.setMaxIterations(opt.max_iterations)
    params.setRelativeErrorTol(rule.relative_tol)
    params.setAbsoluteErrorTol(rule.absolute_tol)
    return params, make


def _gtsam_optimizer(problem: PlanningProblem, config: PlannerConfig,
                     on_iteration: IterationHook | None = None):
    """GTSAM's optimizer for ``config`` on the problem's graph and initial values;
    ``on_iteration(iteration, error_before, error_after)`` is called after each iteration."""
    params, make = gtsam_params(config)
    if on_iteration is not None:
        params.iterationHook = on_iteration
    return make(problem.graph(), problem.values(), params)


class _CurrentValues:
    """A Python reference to the optimizer's current Values, so that GTSAM's linearizations
    hand every CustomFactor that object instead of a copy (see the module docstring)."""

    def __init__(self) -> None:
        self.optimizer = None
        self.values: gtsam.Values | None = None

    def hold(self, optimizer) -> None:
        self.optimizer = optimizer
        self.renew()

    def renew(self) -> None:
        """After an iteration: the optimizer's new current Values."""
        if self.optimizer is not None:
            self.values = self.optimizer.values()

    def release(self) -> None:
        """Drop both references (the iteration hook would otherwise keep the optimizer alive
        through a cycle Python cannot see: optimizer -> params -> hook -> this)."""
        self.optimizer = self.values = None


@dataclass(frozen=True)
class Optimized:
    """theta (T, 2n) at the optimum, iterations, trials, errors, stop reason, phase seconds."""

    theta: np.ndarray
    iterations: int
    trials: int
    initial_error: float
    final_error: float
    stop_reason: str
    timings: dict[str, float]
    optimizer: str


def optimize(problem: PlanningProblem, config: PlannerConfig | None = None,
             warm_start: WarmStart | None = None,
             halt: Callable[[], bool] | None = None) -> Optimized:
    """Optimise ``problem`` from its initial trajectory with ``config.optimizer``.

    The fast solver needs every factor on one or two neighbouring states; otherwise GTSAM's
    Levenberg-Marquardt runs on the graph (logged). ``warm_start``: the fast solver's
    warm-start rule (:class:`clamp.optim.solver.WarmStart`) for an initial trajectory near the
    optimum; GTSAM's optimizers ignore it. ``halt()``: the fast solver stops where it is when
    it returns True (checked every iteration; e.g. a deadline); GTSAM's optimizers run on.
    """
    as_instance(problem, "problem", PlanningProblem, "a clamp PlanningProblem (from clamp.build)",
                ClampTypeError)
    config = as_config(config)
    opt = config.optimizer
    name = opt.optimizer
    if name == "fast" and not problem.banded:
        log.warning("extra factors connect non-neighbouring states: using GTSAM's "
                    "Levenberg-Marquardt instead of the fast solver")
        name = "gtsam"
        config = config.with_(optimizer="gtsam")
    if name == "fast":
        out = levenberg_marquardt(problem, problem.initial, lambda_max=LAMBDA_UPPER_BOUND,
                                  max_iterations=opt.max_iterations,
                                  **opt.stopping_rule().solver_arguments(),
                                  warm_start=warm_start, halt=halt)
        return Optimized(out.theta, out.iterations, out.trials, out.initial_error,
                         out.final_error, out.stop_reason, out.timings, name)
    current = _CurrentValues()
    with progress(description=f"optimizing ({name})", total=opt.max_iterations, unit="iter",
                  delay=PROGRESS_DELAY) as bar:
        counted = [0]

        def on_iteration(iteration: int, error_before: float, error_after: float) -> None:
            current.renew()
            if iteration == counted[0]:   # GTSAM calls the hook after a try that took no step
                log.debug("%s: no decrease from error %.6g", name, error_before)
                return
            counted[0] = iteration
            log.debug("%s iteration %d: error %.6g -> %.6g", name, iteration, error_before, error_after)
            bar.set_postfix(error=f"{error_after:.4g}", refresh=False)
            bar.update()

        optimizer = _gtsam_optimizer(problem, config, on_iteration)
        initial_error = float(optimizer.error())
        current.hold(optimizer)
        try:
            values = optimizer.optimize()
        finally:
            current.release()
    iterations = int(optimizer.iterations())
    stop = "max_iterations" if iterations >= opt.max_iterations else "converged"
    return Optimized(values_to_states(values, problem.keys), iterations, 0, initial_error,
                     float(optimizer.error()), stop, {}, name)
