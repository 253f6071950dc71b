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
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict
from typing import Any, Union

import gtsam
import numpy as np

from clamp.clearance import check_clearance, contact_obstacle
from clamp.conditioning import planning_prior, skill_reference
from clamp.config import PlannerConfig
from clamp.constrained import Candidate, Feasibility, Judge, Progress, solve_constrained
from clamp.detours import detour_restarts
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
              problem: PlanningProblem) -> Callable[[Progress], Iterable[Candidate]]:
    """Other starts when the problem as built fails its checks (see :mod:`clamp.constrained`):
    detours of the initial path around the obstacle nearest the closest optimum, a straight line
    in joint space, and, while none is feasible, the problem without the posture tie from the
    configured initialisation (the arm may then turn further than the free plan)."""
    def generate(progress: Progress) -> Iterable[Candidate]:
        report = progress.closest.reports.get(ObstacleFamily.name) if progress.closest else None
        if report is not None and report.nearest is not None:
            for name, theta in detour_restarts(
                    robot, init.path, request.q_start, float(prior.dt),
                    contact_obstacle(robot, scene, report.nearest), config.model.epsilon,
                    report.nearest.index, config.checks.ik_tolerance):
                yield Candidate(name, problem.with_families(problem.families, theta))
        if config.optimizer.initialisation != "straight_line":
            line = _initialise(prior, robot, request, config.with_(initialisation="straight_line"))
            yield Candidate("straight_line", problem.with_families(problem.families, line.theta))
        if problem.has(PostureFamily.name) and not progress.feasible:
            yield Candidate("untied", _without(problem, PostureFamily.name, init.theta))
    return generate


def _judge(prior: Any, robot: Any, scene: Any, request: Request, config: PlannerConfig,
           reference: Any, families: Sequence[Family], obstacles: bool) -> Judge:
    """The verdict's checks of an optimum theta (T, 2n), as the constrained solve needs them:
    obstacle collision on the robot's collision geometry (first: the others only run on a clear
    plan), the joint limits and constraint families (:func:`clamp.targets.violated_families`),
    self-collision, and with obstacles the skill checks (a collision-free plan that leaves the
    skill is not accepted)."""
    time_ = np.asarray(prior.time, dtype=float)

    def judge(theta: np.ndarray) -> Feasibility:
        q, reports, clearance = theta[:, :robot.n], {}, math.inf
        if obstacles:
            report = check_clearance(robot, scene, q, time_)
            reports[ObstacleFamily.name], clearance = report, float(report.min_distance)
            if report.collision:
                return Feasibility((ObstacleFamily.name,), True, reports, clearance)
        violated = violated_families(families, robot, theta, config)
        own = self_collision_report(robot, q, time_)
        reports[SelfCollisionFamily.name] = own
        if own.collision:
            violated.append(SelfCollisionFamily.name)
        accepted = not obstacles or bool(violated) or not skill_checks(
            prior, reference, robot.fk(q), request.goal is not None, score=False).reasons
        return Feasibility(tuple(violated), accepted, reports, clearance)
    return judge


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
    reference = skill_reference(prior, robot, request, config, model_prior)
    obstacles = problem.has(ObstacleFamily.name)
    model = config.model
    lazy = {SelfCollisionFamily.name: lambda: SelfCollisionFamily.for_robot(
        robot, range(T - 1), model.self_collision_epsilon, model.self_collision_sigma,
        SELF_COLLISION_BETWEEN)}
    solved = solve_constrained(
        problem, config, _judge(prior, robot, scene, request, config, reference,
                                problem.families, obstacles),
        _restarts(prior, robot, scene, request, config, init, problem) if obstacles
        else lambda _: (), lazy, warm_start)
    problem, out = solved.problem, solved.out
    report = solved.feasibility.reports.get(ObstacleFamily.name)
    own = solved.feasibility.reports.get(SelfCollisionFamily.name)
    attempts = [asdict(a) for a in solved.attempts]
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
    result.problem = problem
    result.state_covariance, result.ee_covariance = state_cov, ee_cov
    result.covariance_floor = floor
    result.inputs = PlanInputs(prior, robot, scene, start, goal, tuple(via_points),
                               tuple(extra_factors), config, sdf, model_prior)
    result.timings["total"] = time.perf_counter() - t0
    return result
