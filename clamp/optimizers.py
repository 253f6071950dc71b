"""The optimizers a planning problem can be solved with, in one place.

:data:`OPTIMIZERS`: "fast" (:func:`clamp.solver.levenberg_marquardt` on the state array) and
GTSAM's Levenberg-Marquardt, Dogleg and Gauss-Newton on ``problem.graph()``. Adding or swapping
an optimizer touches this file only.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import gtsam
import numpy as np

from clamp.config import PlannerConfig
from clamp.errors import ArgumentTypeError
from clamp.keys import values_to_states
from clamp.problem import PlanningProblem
from clamp.request import as_config
from clamp.solver import WarmStart, levenberg_marquardt
from scenes.validation import as_instance

log = logging.getLogger(__name__)

#: valid ``PlannerConfig.optimizer.optimizer`` names
OPTIMIZERS = ("fast", "gtsam", "gtsam_dogleg", "gtsam_gauss_newton")


def _gtsam_optimizer(problem: PlanningProblem, config: PlannerConfig):
    opt = config.optimizer
    graph, values = problem.graph(), problem.values()
    if opt.optimizer == "gtsam":
        params = gtsam.LevenbergMarquardtParams()
        params.setlambdaInitial(opt.lambda_initial)
        params.setlambdaUpperBound(opt.lambda_upper_bound)
        make = gtsam.LevenbergMarquardtOptimizer
    elif opt.optimizer == "gtsam_dogleg":
        params, make = gtsam.DoglegParams(), gtsam.DoglegOptimizer
    else:
        params, make = gtsam.GaussNewtonParams(), gtsam.GaussNewtonOptimizer
    # QR: the stiff learned prior makes the undamped normal equations too ill-conditioned
    # for Cholesky (GTSAM reports an indeterminate system)
    params.setLinearSolverType("MULTIFRONTAL_QR")
    params.setMaxIterations(opt.max_iterations)
    params.setRelativeErrorTol(opt.relative_error_tol)
    params.setAbsoluteErrorTol(opt.absolute_error_tol)
    return make(graph, values, params)


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
             warm_start: WarmStart | None = None) -> Optimized:
    """Optimise ``problem`` from its initial trajectory with ``config.optimizer``.

    The fast solver needs every factor on one or two neighbouring states; otherwise GTSAM's
    Levenberg-Marquardt runs on the graph (logged). ``warm_start``: the fast solver's
    warm-start rule (:class:`clamp.solver.WarmStart`) for an initial trajectory near the
    optimum; GTSAM's optimizers ignore it.
    """
    as_instance(problem, "problem", PlanningProblem, "a clamp PlanningProblem (from clamp.build)",
                ArgumentTypeError)
    config = as_config(config)
    opt = config.optimizer
    name = opt.optimizer
    if name == "fast" and not problem.banded:
        log.warning("extra factors connect non-neighbouring states: using GTSAM's "
                    "Levenberg-Marquardt instead of the fast solver")
        name = "gtsam"
        config = config.with_(optimizer="gtsam")
    if name == "fast":
        out = levenberg_marquardt(problem, problem.initial, lambda_initial=opt.lambda_initial,
                                  lambda_max=opt.lambda_upper_bound,
                                  max_iterations=opt.max_iterations,
                                  relative_tol=opt.relative_error_tol,
                                  absolute_tol=opt.absolute_error_tol,
                                  patience=opt.convergence_patience,
                                  workspace_correction=opt.workspace_correction,
                                  warm_start=warm_start)
        return Optimized(out.theta, out.iterations, out.trials, out.initial_error,
                         out.final_error, out.stop_reason, out.timings, name)
    optimizer = _gtsam_optimizer(problem, config)
    initial_error = float(optimizer.error())
    values = optimizer.optimize()
    iterations = int(optimizer.iterations())
    stop = "max_iterations" if iterations >= opt.max_iterations else "converged"
    return Optimized(values_to_states(values, problem.keys), iterations, 0, initial_error,
                     float(optimizer.error()), stop, {}, name)
