"""CLAMP planner: MAP inference of a joint trajectory under the learned workspace prior.

:func:`build` turns a request (prior, robot, scene, start, goal, via points, extra factors)
into a :class:`~clamp.problem.PlanningProblem` over joint states theta_i = [q_i, qdot_i] of
the prior's T support states, with the families: learned workspace GP, workspace start,
constant-velocity joint GP, joint / end-effector targets (start, goal, via points), obstacle
hinges, joint-limit hinges, plus the caller's families and GTSAM factors (paper eq. 14-20).
:func:`plan` optimises it (the fast solver of :mod:`clamp.solver` by default, or one of GTSAM's
optimizers on ``problem.graph()``), computes the posterior covariance at the optimum and
checks the result.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, replace
from typing import Any, Union

import gtsam
import numpy as np

from clamp.clearance import check_clearance, contact_obstacle
from clamp.conditioning import planning_prior, skill_reference
from clamp.config import PlannerConfig
from clamp.continuation import (Attempt, detour_restarts, solve_collision_free,
                                tighten_constraints, with_obstacle_sigma)
from clamp.errors import InvalidParameterError
from clamp.factors import (EEPositionFamily, Family, JointGPFamily, JointLimitFamily,
                           JointTargetFamily, ObstacleFamily, PostureFamily,
                           SelfCollisionFamily, WorkspaceGPFamily,
                           WorkspaceStartFamily, shifted_start_mean)
from clamp.initialisation import (Initialisation, joint_velocities, prior_mean_initialisation,
                                  straight_line_initialisation)
from clamp.keys import state_key
from clamp.optimizers import optimize
from clamp.problem import PlanningProblem
from clamp.request import (Request, Target, as_config, as_extras, as_scene, as_sdf, check_prior,
                           check_robot, has_obstacles, make_request)
from clamp.result import PlanInputs, PlanResult
from clamp.skill import skill_checks
from clamp.targets import target_problems, violated_families
from clamp.uncertainty import plan_covariances
from clamp.validation import as_array, as_bool
from clamp.solver import WarmStart
from clamp.verdict import evaluate, failed_result, start_problems
from robots.self_collision import self_collision_report
from scenes.threads import single_blas_thread

#: configurations checked between two states by the self-collision hinges (a link swept
#: through another between states is caught)
SELF_COLLISION_BETWEEN = 8

PerStateFactorMaker = Callable[[int, int, int], Union[gtsam.NonlinearFactor, None]]
#: what ``extra_factors`` may hold: a family (fast path), any GTSAM factor on the planner's
#: state keys, or a maker(index, num_states, key) -> factor | None called for every state
ExtraFactor = Union[Family, gtsam.NonlinearFactor, PerStateFactorMaker]


# ---------------------------------------------------------------------------------- building
def _initialise(prior: Any, robot: Any, request: Request, config: PlannerConfig) -> Initialisation:
    T, dt = prior.Phi.shape[0] + 1, float(prior.dt)
    mean_path = np.asarray(prior.mean)[:, :3]
    opt, goal = config.optimizer, request.goal
    if opt.initialisation == "prior_mean":
        goal_position = None
        if goal is not None:
            goal_position = goal.value if goal.kind == "position" else robot.fk(goal.value)
        return prior_mean_initialisation(robot, mean_path, dt, request.q_start, goal_position,
                                         opt.blend_start_offset, config.checks.ik_tolerance)
    if opt.straight_line_configurations is not None:
        first, last = (as_array(c, f"config.optimizer.straight_line_configurations[{k}]",
                                (robot.n,))
                       for k, c in enumerate(opt.straight_line_configurations))
    else:
        first = request.q_start
        if goal is not None and goal.kind == "joint":
            last = goal.value
        else:
            end = goal.value if goal is not None else mean_path[-1]
            last = np.asarray(robot.ik(end, seed=first, tol=config.checks.ik_tolerance).q,
                              dtype=float)
    return straight_line_initialisation(robot, first, last, T, dt)


def _restarts(prior, robot, scene, request: Request, config: PlannerConfig, init: Initialisation,
              report: Any):
    """Other starting trajectories when the plan collides: detours of the initial path around
    the obstacle of the deepest contact, then a straight line in joint space."""
    yield from detour_restarts(robot, init.path, request.q_start, float(prior.dt),
                               contact_obstacle(robot, scene, report.nearest),
                               config.model.epsilon, report.nearest.index,
                               config.checks.ik_tolerance)
    if config.optimizer.initialisation != "straight_line":
        line = _initialise(prior, robot, request, config.with_(initialisation="straight_line"))
        yield "straight_line", line.theta


def _free_of_self_collision(problem: PlanningProblem, out: Any, config: PlannerConfig,
                            check: Callable | None, report: Any, time_: np.ndarray,
                            attempts: list[dict]) -> tuple:
    """When the plan ``out`` collides with itself (:func:`robots.self_collision_report`),
    re-solve from it with the self-collision hinges added (:class:`SelfCollisionFamily`,
    ``config.model.self_collision_epsilon`` / ``_sigma``), kept if it brings no obstacle
    collision back; appends the attempt. Returns (problem, out, obstacle report, self report)
    of the plan chosen."""
    robot, T = problem.robot, problem.num_states
    own = self_collision_report(robot, out.theta[:, :robot.n], time_)
    if not own.collision or config.optimizer.constraint_rounds == 0:
        return problem, out, report, own
    model = config.model
    family = SelfCollisionFamily.for_robot(robot, range(T - 1), model.self_collision_epsilon,
                                           model.self_collision_sigma, SELF_COLLISION_BETWEEN)
    guarded = problem.with_families([*problem.families, family], out.theta)
    new = optimize(guarded, config, WarmStart())
    new_own = self_collision_report(robot, new.theta[:, :robot.n], time_)
    new_report = check(new.theta) if check is not None else None
    collides = new_report is not None and new_report.collision
    attempts.append(asdict(Attempt("self-collision hinges", model.self_collision_sigma,
                                   float(new_own.min_distance), not collides, float("nan"),
                                   new.iterations)))
    if collides and not (report is not None and report.collision):
        return problem, out, report, own
    new = replace(new, iterations=out.iterations + new.iterations,
                  trials=out.trials + new.trials, initial_error=out.initial_error)
    return guarded, new, new_report, new_own


def warm_start(robot: Any, initial: Any, T: int, dt: float) -> Initialisation:
    """Initialisation from a given trajectory: q (T, n) or joint states [q, qdot] (T, 2n)."""
    n = robot.n
    if np.ndim(initial) == 2 and np.shape(initial)[1] == 2 * n:
        theta = as_array(initial, "initial", (T, 2 * n))
        q, qdot = theta[:, :n], theta[:, n:]
    else:
        q = as_array(initial, "initial", (T, n))
        qdot = joint_velocities(q, dt)
    return Initialisation(q, qdot, robot.fk(q), np.zeros(T))


def distance_query(scene: Any, config: PlannerConfig, sdf: Any = None,
                   reach: float = math.inf) -> Callable | None:
    """The signed-distance query the obstacle family uses: ``sdf.query`` when given, else the
    scene's (exact for primitives, a grid cached by the scene otherwise), clipped at ``reach``
    [m] (the hinge's: epsilon + the largest sphere radius), so that only the obstacles near the
    arm are evaluated; None without obstacles or with obstacle factors off."""
    sdf = as_sdf(sdf, scene)
    if not config.model.obstacle_factors or not has_obstacles(scene):
        return None
    if sdf is not None:
        return sdf.query
    return scene.distance_query(config.model.sdf_cell_size, max_distance=reach)


def _families(prior: Any, robot: Any, request: Request, config: PlannerConfig,
              query: Callable | None) -> list[Family]:
    """The planner's own factor families for ``request``."""
    T, n, dt, model = prior.Phi.shape[0] + 1, robot.n, float(prior.dt), config.model
    families: list[Family] = [WorkspaceGPFamily(prior.Phi, prior.u, prior.Q)]
    if model.workspace_start:
        families.append(WorkspaceStartFamily(
            shifted_start_mean(np.asarray(prior.mean0), request.start_position),
            np.asarray(prior.cov0)))
    families.append(JointGPFamily(T, n, dt, model.Qc))
    start = request.start
    if start.kind == "position" and model.fix_start_configuration:
        # the IK solution becomes the start: a fully determined theta_0 keeps the problem
        # well conditioned (an end-effector start leaves the arm's self-motion free)
        start = Target("joint", request.q_start)
    targets = [(0, start, model.start_sigma)]
    if request.goal is not None:
        targets.append((T - 1, request.goal, model.goal_sigma))
    targets += [(i, target, model.via_sigma) for i, target in request.vias]
    for kind, family in (("joint", JointTargetFamily), ("position", EEPositionFamily)):
        chosen = [(i, t.value, s) for i, t, s in targets if t.kind == kind]
        if chosen:
            index, value, sigma = zip(*chosen)
            families.append(family(index, np.array(value), sigma))
    if query is not None:
        families.append(ObstacleFamily(np.arange(T), robot.spheres.radii, query, model.epsilon,
                                       model.sigma_obs))
    if model.joint_limits:
        families.append(JointLimitFamily(np.arange(T), robot.lower_limits, robot.upper_limits,
                                         robot.velocity_limits, model.limit_sigma,
                                         model.limit_margin, model.velocity_margin))
    return families


def _extras(extra_factors: Sequence[ExtraFactor], T: int
            ) -> tuple[list[Family], list[gtsam.NonlinearFactor]]:
    families, factors = [], []
    for k, extra in enumerate(as_extras(extra_factors)):
        if isinstance(extra, Family):
            if len(extra) and (extra.first.min() < 0 or extra.first.max() + extra.arity > T):
                raise InvalidParameterError(f"extra_factors[{k}]: family {extra.name!r} uses "
                                            f"states outside 0..{T - 1}")
            families.append(extra)
        elif isinstance(extra, gtsam.NonlinearFactor):
            factors.append(extra)
        elif callable(extra):
            for i in range(T):
                made = extra(i, T, state_key(i))
                if made is None:
                    continue
                if not isinstance(made, gtsam.NonlinearFactor):
                    raise InvalidParameterError(f"extra_factors[{k}]: the maker returned "
                                                f"{type(made).__name__} for state {i}, expected "
                                                "a gtsam.NonlinearFactor or None")
                factors.append(made)
        else:
            raise InvalidParameterError(f"extra_factors[{k}]: expected a clamp Family, a "
                                        f"gtsam.NonlinearFactor or a callable maker(index, "
                                        f"num_states, key), got {type(extra).__name__}")
    return families, factors


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
    problem, _, _, _ = _build(prior, robot, as_scene(scene), start, goal, via_points,
                           extra_factors, as_config(config), sdf, initial)
    return problem


def _build(prior, robot, scene, start, goal, via_points, extra_factors, config, sdf, initial,
           request: Request | None = None, model_prior: Any = None
           ) -> tuple[PlanningProblem, Request, Initialisation, Any]:
    check_prior(prior)
    check_robot(robot)
    T, dt = prior.Phi.shape[0] + 1, float(prior.dt)
    request = request or make_request(prior, robot, start, goal, via_points, config)
    extra_families, foreign = _extras(extra_factors, T)
    if model_prior is None:                       # the prior conditioned on the targets
        model_prior = planning_prior(prior, robot, request, config)
    families = _families(model_prior, robot, request, config, distance_query(
        scene, config, sdf, config.model.epsilon + float(np.max(robot.spheres.radii, initial=0.0))))
    init = (_initialise(model_prior, robot, request, config) if initial is None
            else warm_start(robot, initial, T, dt))
    problem = PlanningProblem(robot, T, families + extra_families, foreign, init.theta)
    if config.model.posture_sigma > 0 and problem.has(ObstacleFamily.name):
        problem = tied_to_free_plan(problem, config, keep_initial=initial is not None)
    return problem, request, init, model_prior


def tied_to_free_plan(problem: PlanningProblem, config: PlannerConfig,
                      keep_initial: bool = False) -> PlanningProblem:
    """``problem`` with every state's configuration tied to the free plan (a
    :class:`~clamp.factors.PostureFamily` of noise ``config.model.posture_sigma``), starting
    from the free plan unless ``keep_initial``. The free plan is ``problem`` without its
    obstacle hinges, optimised as configured (one extra solve, ~20 ms): where it keeps clear of
    every obstacle by ``epsilon`` it is the tied problem's optimum as it is."""
    theta = optimize(_without(problem, ObstacleFamily.name, problem.initial), config).theta
    T, n = problem.num_states, problem.robot.n
    posture = PostureFamily(np.arange(T), theta[:, :n], np.full(T, config.model.posture_sigma))
    return problem.with_families([*problem.families, posture],
                                 problem.initial if keep_initial else theta)


def _without(problem: PlanningProblem, name: str, initial: np.ndarray) -> PlanningProblem:
    """``problem`` without the family called ``name``, starting at initial (T, 2n)."""
    return problem.with_families([f for f in problem.families if f.name != name], initial)


def plan(prior: Any, robot: Any, scene: Any = None, start: Any = None, goal: Any = None,
         via_points: Sequence[tuple[int, Any]] = (), extra_factors: Sequence[ExtraFactor] = (),
         config: PlannerConfig | None = None, sdf: Any = None,
         initial: np.ndarray | None = None, covariance: bool = True) -> PlanResult:
    """Reproduce the skill of ``prior`` with ``robot`` from ``start`` in ``scene``.

    Arguments as for :func:`build`; covariance: compute the posterior covariance of every
    state (``PlanResult.state_covariance`` / ``ee_covariance``). A start that is out of reach
    or in collision gives ``success=False`` with a reason (no exception); bad input raises
    ClampError subclasses.
    """
    with single_blas_thread():  # small products only: one BLAS thread (see scenes.threads)
        return _plan(prior, robot, scene, start, goal, via_points, extra_factors, config, sdf,
                     initial, covariance)


def _plan(prior, robot, scene, start, goal, via_points, extra_factors, config, sdf, initial,
          covariance, q_start: np.ndarray | None = None, model_prior: Any = None,
          warm_start: Any = None) -> PlanResult:
    t0 = time.perf_counter()
    config = as_config(config)
    covariance = as_bool(covariance, "covariance")
    check_prior(prior)
    check_robot(robot)
    scene = as_scene(scene)
    request = make_request(prior, robot, start, goal, via_points, config, q_start)
    T = prior.Phi.shape[0] + 1
    reasons = (start_problems(robot, scene, request, config)
               + target_problems(robot, request, config, scene))
    if reasons:
        return failed_result(prior, robot, np.repeat(request.q_start[None], T, axis=0), reasons, t0,
                       request.start_ik_error, config)
    problem, request, init, model_prior = _build(prior, robot, scene, start, goal, via_points,
                                                 extra_factors, config, sdf, initial, request,
                                                 model_prior)
    t_opt = time.perf_counter()
    report, attempts = None, []
    base, sigma, check = problem, float("nan"), None
    reference = skill_reference(prior, robot, request, config, model_prior)
    if problem.has(ObstacleFamily.name):
        # collision-free is a constraint: continuation on the hinge and restarts (see
        # clamp.continuation), judged on the robot's own collision geometry
        def check(theta):
            return check_clearance(robot, scene, theta[:, :robot.n], prior.time)

        def restarts(found):
            return _restarts(prior, robot, scene, request, config, init, found)

        def with_the_skill(theta):
            return not skill_checks(prior, reference, robot.fk(theta[:, :robot.n]),
                                    request.goal is not None, score=False).reasons
        solved = solve_collision_free(problem, config, check, restarts,
                                      config.optimizer.constraint_rounds, warm_start,
                                      with_the_skill)
        attempts = list(solved.attempts)
        if solved.report.collision and problem.has(PostureFamily.name):
            # the free plan's posture leads into the obstacles however loose the tie: plan
            # without it from the configured initialisation (the arm may then turn further)
            untied = _without(problem, PostureFamily.name, init.theta)
            alternative = solve_collision_free(untied, config, check, restarts,
                                               config.optimizer.constraint_rounds)
            attempts += [replace(a, candidate="untied " + a.candidate)
                         for a in alternative.attempts]
            if not alternative.report.collision:
                problem, solved = untied, alternative
        out, report, sigma = solved.out, solved.report, solved.sigma
        base = with_obstacle_sigma(problem, sigma, problem.initial)
    else:
        out = optimize(problem, config, warm_start)
    # the other soft constraints (limits, orientation): stiffer while the verdict finds them
    # violated
    out, report, tightened = tighten_constraints(
        problem, base, out, config,
        lambda theta: violated_families(problem.families, robot, theta, config),
        check, config.optimizer.constraint_rounds, report, sigma)
    attempts = [asdict(a) for a in attempts + tightened]
    problem, out, report, own = _free_of_self_collision(problem, out, config, check, report,
                                                        np.asarray(prior.time, dtype=float),
                                                        attempts)
    t_cov = time.perf_counter()
    state_cov = ee_cov = None
    floor = 0.0
    faults = []
    if covariance and problem.banded:
        try:
            state_cov, ee_cov, floor = plan_covariances(problem, out.theta)
        except (InvalidParameterError, np.linalg.LinAlgError) as exc:
            # a fault of the plan's own numbers (e.g. a time step of microseconds), not of the
            # caller's input: the verdict says so instead of raising
            faults.append(f"posterior covariance failed: {exc}")
    t_end = time.perf_counter()
    timings = {"build": t_opt - t0, "optimize": t_cov - t_opt, "marginals": t_end - t_cov,
               **out.timings}
    result = evaluate(prior, robot, scene, problem, request, out, config, timings, report,
                      reference, own, faults)
    result.initial_q = init.q
    result.attempts = attempts
    result.state_covariance, result.ee_covariance = state_cov, ee_cov
    result.covariance_floor = floor
    result.inputs = PlanInputs(prior, robot, scene, start, goal, tuple(via_points),
                               tuple(extra_factors), config, sdf, model_prior)
    result.timings["total"] = time.perf_counter() - t0
    return result
