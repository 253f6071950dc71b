"""CLAMP planner: MAP inference of a joint trajectory under the learned workspace prior.

:func:`build` turns a request (prior, robot, scene, start, goal, via points, extra factors)
into a :class:`~clamp.graph.problem.PlanningProblem` over joint states theta_i = [q_i, qdot_i] of
the prior's T support states, with the families: learned workspace GP, workspace start,
constant-velocity joint GP, joint / end-effector targets (start, goal, via points), obstacle
hinges, joint-limit hinges, plus the caller's families and GTSAM factors (paper eq. 14-20).
:func:`plan` runs the stages of :mod:`clamp.planning.pipeline`: the request, the model (that problem),
its solution (the fast solver of :mod:`clamp.optim.solver` by default, or one of GTSAM's optimizers
on ``problem.graph()``), the posterior covariance at the optimum and the verdict.
"""
from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from clamp.planning.assembly import ExtraFactor
from clamp.config import PlannerConfig
from clamp.planning.pipeline import Model, build_model, posterior, solve
from clamp.planning.search import Budget
from clamp.graph.problem import PlanningProblem
from clamp.config import as_config
from clamp.planning.request import as_extras, as_scene, make_request
from clamp.planning.result import PlanResult
from clamp.optim.solver import WarmStart
from clamp.planning.targets import target_problems
from clamp.config import as_max_duration, as_time_scale
from clamp.planning.time_scale import plan_time_scaled
from clamp.validation import as_bool
from clamp.planning.verdict import evaluate, failed_result, start_problems
from skillplan.threads import single_blas_thread


#: plan()'s budget and deadline when not given: the config's
CONFIGURED: Any = object()


def build(prior: Any, robot: Any, scene: Any = None, start: Any = None, goal: Any = None,
          via_points: Sequence[tuple[int, Any]] = (), extra_factors: Sequence[ExtraFactor] = (),
          config: PlannerConfig | None = None, sdf: Any = None,
          initial: np.ndarray | None = None) -> PlanningProblem:
    """The planning problem for reproducing ``prior`` with ``robot`` from ``start``.

    prior: clamp.WorkspacePrior (T support states, step dt); robot: robots.Robot (n joints);
    scene: scenes.Scene, obstacle(s), a scene file or None; start: joint configuration (n,)
    [rad] or end-effector position (3,) [m]; goal: the same kinds, or None; via_points:
    (index, position (3,) or configuration (n,)); extra_factors: see :data:`ExtraFactor`;
    sdf: a precomputed scenes.SignedDistanceField to use instead of the scene's own distance;
    initial: a warm start, joint positions (T, n) or joint states (T, 2n) (e.g. a previous
    plan), replacing the configured initialisation. ``problem.graph()`` and
    ``problem.values()`` give the GTSAM graph and initial values. Raises ClampError
    subclasses on bad input.
    """
    config = as_config(config)
    request = make_request(prior, robot, start, goal, via_points, config)
    return build_model(prior, robot, as_scene(scene), request, config, tuple(as_extras(extra_factors)),
                       sdf, initial).problem


def plan(prior: Any, robot: Any, scene: Any = None, start: Any = None, goal: Any = None,
         via_points: Sequence[tuple[int, Any]] = (), extra_factors: Sequence[ExtraFactor] = (),
         config: PlannerConfig | None = None, sdf: Any = None,
         initial: np.ndarray | None = None, covariance: bool = True,
         time_scale: float | None = None, max_duration: float | None = None,
         budget: Any = CONFIGURED, deadline: Any = CONFIGURED) -> PlanResult:
    """Reproduce the skill of ``prior`` with ``robot`` from ``start`` in ``scene``.

    Arguments as for :func:`build`; covariance: compute the posterior covariance of every
    state (``PlanResult.state_covariance`` / ``ee_covariance``). A start that is out of reach
    or in collision gives ``success=False`` with a reason (no exception); bad input raises
    ClampError subclasses. The stages (:mod:`clamp.planning.pipeline`): request -> model -> solution ->
    posterior -> verdict, timed ("build", "optimize", "marginals", "total"). time_scale (>= 1)
    / max_duration [s]: plan the skill that many times slower / at most that long (None:
    ``config.model``'s; by default as slow as the arm's velocity limits need,
    ``PlanResult.time_scale``; :mod:`clamp.planning.time_scale`). budget: the work the search
    may spend, in units of its first solves (None: unbounded); deadline [s]: of the whole
    call (None: none); both ``config.optimizer``'s unless given (:mod:`clamp.planning.search`;
    ``PlanResult.search`` says what was spent and whether the budget ended the search).
    """
    started = time.perf_counter()
    config, scene = as_config(config), as_scene(scene)
    given = {name: value for name, value in (("budget", budget), ("deadline", deadline))
             if value is not CONFIGURED}
    config = config.with_(**given) if given else config
    covariance = as_bool(covariance, "covariance")
    time_scale, max_duration = as_time_scale(time_scale), as_max_duration(max_duration)
    with single_blas_thread():  # small products only: one BLAS thread (see skillplan.threads)
        request = make_request(prior, robot, start, goal, via_points, config)
        reasons = (start_problems(robot, scene, request, config)
                   + target_problems(robot, request, config, scene))
        if reasons:
            T = prior.Phi.shape[0] + 1
            return failed_result(prior, robot, np.repeat(request.q_start[None], T, axis=0),
                                 reasons, started, request.start_ik_error, config)

        def plan_at(scaled_prior: Any, scaled_config: PlannerConfig) -> PlanResult:
            planned = build_model(scaled_prior, robot, scene, request, scaled_config,
                                  tuple(as_extras(extra_factors)), sdf, initial)
            return plan_model(planned, covariance, started=started)
        return plan_time_scaled(plan_at, prior, robot, config, time_scale, max_duration)


def plan_model(planned: Model, covariance: bool = True, warm_start: WarmStart | None = None,
               started: float | None = None) -> PlanResult:
    """The plan of a :class:`~clamp.planning.pipeline.Model`: its solution (``warm_start``: the fast
    solver's warm-start rule), posterior (``covariance``: computed or not) and verdict, the
    later stages of :func:`plan`. Timings [s]: "build" from ``started`` (``time.perf_counter()``
    before the request was made; None: now) to the solve, "optimize", "marginals", "total"."""
    started = time.perf_counter() if started is None else started
    t_solve = time.perf_counter()
    optimizer = planned.config.optimizer
    solution = solve(planned, warm_start, Budget(optimizer.budget, optimizer.deadline, started))
    t_posterior = time.perf_counter()
    belief = posterior(planned, solution, covariance)
    timings = {"build": t_solve - started, "optimize": t_posterior - t_solve,
               "marginals": time.perf_counter() - t_posterior, **solution.optimum.timings}
    return evaluate(planned, solution, belief, timings, started)
