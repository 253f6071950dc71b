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
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from clamp.planning.assembly import ExtraFactor
from clamp.config import PlannerConfig
from clamp.planning.pipeline import Model, Solution, build_model, posterior, solve
from clamp.planning.search import Budget
from clamp.graph.problem import PlanningProblem
from clamp.config import as_config
from clamp.planning.request import as_extras, as_scene, make_request
from clamp.planning.result import PlanResult
from clamp.optim.solver import WarmStart
from clamp.planning.targets import target_problems
from clamp.config import as_max_duration, as_time_scale
from clamp.planning.time_scale import (TimeRequest, chosen_scale, fail, needed_scale,
                                       time_request, time_scaled_config, time_scaled_prior,
                                       timing_reasons)
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
    [rad] or end-effector position (3,) [m]; goal: the same kinds, a pose (a transform
    (4, 4), or (position (3,), quaternion (4,) x, y, z, w): its rotation is met too, for a
    pose prior through its orientation chain), or None; via_points: (index, position (3,),
    configuration (n,) or pose); extra_factors: see :data:`ExtraFactor`;
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
        timing = time_request(prior, config, time_scale, max_duration)
        reasons = (start_problems(robot, scene, request, config)
                   + target_problems(robot, request, config, scene))
        if reasons:
            T = prior.Phi.shape[0] + 1
            return failed_result(prior, robot, np.repeat(request.q_start[None], T, axis=0),
                                 reasons, started, request.start_ik_error, config)

        extras = tuple(as_extras(extra_factors))

        def model_at(k: float, **start: np.ndarray) -> Model:
            """The model of the request with the skill traversed k times slower (``start``:
            build_model's ``initial`` / ``free`` instead of the configured ones)."""
            return build_model(time_scaled_prior(prior, k), robot, scene, request,
                               time_scaled_config(config, k), extras, sdf,
                               **{"initial": initial, **start})
        return _planned_in_time(model_at, timing, covariance, started)


def _planned_in_time(model_at: Callable[..., Model], timing: TimeRequest, covariance: bool,
                     started: float) -> PlanResult:
    """The time stage, then the path solve (:mod:`clamp.planning.time_scale`): at the caller's
    scale; else at the scale the free plan needs. With obstacles the free plan is solved when
    the model is built: a skill too fast for the arm is built again at its scale (one more
    free-plan solve). In an empty scene the plan is the free plan: the skill followed at its
    demonstrated speed (the initial trajectory) predicts its need. A plan whose path moves
    faster than its scale allows (a detour) is retimed once, at its own need
    (:func:`_retimed`)."""
    if timing.fixed is not None:
        k = timing.fixed
        planned = model_at(k)
        result = plan_model(planned, covariance, started=started)
        needed = k * _needed(planned, np.hstack([result.q, result.qdot]))
        return _timed(result, k, planned, timing, needed)
    planned = model_at(1.0)
    if planned.free_plan is not None:                # obstacles: the free plan is known
        needed = _needed(planned, planned.free_plan, planned.initialisation.q)
    else:                                            # empty: the skill's own speed
        needed = _needed(planned, planned.initialisation.theta)
    k = chosen_scale(timing, needed)
    planned = planned if k == 1.0 else model_at(k)
    solving = time.perf_counter()
    solution = solve(planned, budget=_budget(planned, started))
    beyond = _needed(planned, solution.optimum.theta)
    if beyond > 1.0 and chosen_scale(timing, k * beyond) > k:
        needed = k * beyond
        planned, solution, k = _retimed(model_at, planned, solution, k,
                                        chosen_scale(timing, needed))
    return _timed(_concluded(planned, solution, covariance, started, solving), k, planned,
                  timing, needed)


def _retimed(model_at: Callable[..., Model], planned: Model, solution: Solution, k: float,
             slower: float) -> tuple[Model, Solution, float]:
    """``solution`` of ``planned`` (at scale k) traversed at scale ``slower`` > k, solved no
    more: the same states q, velocities times k / slower, in the model at ``slower`` (its free
    plan ``planned``'s retimed alike). The scaled problem is the same problem in slower time
    (module docstring of :mod:`clamp.planning.time_scale`): the path, its clearance between the
    states (the cubic Hermite segments keep their shape) and its skill checks are the same, every
    joint speed is k / slower times the plan's; the verdict checks it all again."""
    n, ratio = planned.robot.n, k / slower

    def retime(theta: np.ndarray) -> np.ndarray:
        return np.hstack([theta[:, :n], theta[:, n:] * ratio])
    theta = retime(solution.optimum.theta)
    start = {"initial": theta}
    if planned.free_plan is not None:
        start["free"] = retime(planned.free_plan)
    retimed = model_at(slower, **start)
    optimum = replace(solution.optimum, theta=theta,
                      final_error=retimed.problem.error(theta))
    return retimed, Solution(optimum, retimed.problem, solution.report, solution.self_report,
                             solution.attempts), slower


def _timed(result: PlanResult, k: float, planned: Model, timing: TimeRequest,
           needed: float) -> PlanResult:
    """``result`` planned at time scale k, with the time stage's reasons
    (:func:`clamp.planning.time_scale.timing_reasons`) in its verdict."""
    result.time_scale = k
    return fail(result, timing_reasons(result, planned.robot, planned.config, timing, needed))


def _needed(planned: Model, theta: np.ndarray, initial_q: np.ndarray | None = None) -> float:
    """:func:`clamp.planning.time_scale.needed_scale` of theta (T, 2n) in ``planned``."""
    return needed_scale(planned.robot, theta, np.asarray(planned.prior.time, dtype=float),
                        planned.config, initial_q)


def plan_model(planned: Model, covariance: bool = True, warm_start: WarmStart | None = None,
               started: float | None = None) -> PlanResult:
    """The plan of a :class:`~clamp.planning.pipeline.Model`: its solution (``warm_start``: the fast
    solver's warm-start rule), posterior (``covariance``: computed or not) and verdict, the
    later stages of :func:`plan`. Timings [s]: "build" from ``started`` (``time.perf_counter()``
    before the request was made; None: now) to the solve, "optimize", "marginals", "total"."""
    started = time.perf_counter() if started is None else started
    solving = time.perf_counter()
    solution = solve(planned, warm_start, _budget(planned, started))
    return _concluded(planned, solution, covariance, started, solving)


def _budget(planned: Model, started: float) -> Budget:
    """The search's budget of ``planned`` (its optimizer's counted budget and deadline [s]),
    a deadline counted from ``started`` (``time.perf_counter()``)."""
    optimizer = planned.config.optimizer
    return Budget(optimizer.budget, optimizer.deadline, started)


def _concluded(planned: Model, solution: Solution, covariance: bool, started: float,
               solving: float) -> PlanResult:
    """The posterior and verdict of ``solution`` (of ``planned``; solved from
    ``time.perf_counter()`` ``solving`` on, the plan started at ``started``)."""
    t_posterior = time.perf_counter()
    belief = posterior(planned, solution, covariance)
    timings = {"build": solving - started, "optimize": t_posterior - solving,
               "marginals": time.perf_counter() - t_posterior, **solution.optimum.timings}
    return evaluate(planned, solution, belief, timings, started)
