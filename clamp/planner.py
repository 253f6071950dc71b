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

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Union

import gtsam
import numpy as np

from clamp.config import PlannerConfig
from clamp.errors import InvalidParameterError, ShapeError
from clamp.factors import (EEPositionFamily, Family, JointGPFamily, JointLimitFamily,
                           JointTargetFamily, ObstacleFamily, WorkspaceGPFamily,
                           WorkspaceStartFamily, shifted_start_mean)
from clamp.initialisation import (Initialisation, joint_velocities, prior_mean_initialisation,
                                  straight_line_initialisation)
from clamp.keys import state_key
from clamp.optimizers import Optimized, optimize
from clamp.problem import PlanningProblem
from clamp.result import PlanResult
from clamp.uncertainty import plan_covariances
from clamp.validation import as_array, as_count
from scenes.threads import single_blas_thread

PerStateFactorMaker = Callable[[int, int, int], Union[gtsam.NonlinearFactor, None]]
#: what ``extra_factors`` may hold: a family (fast path), any GTSAM factor on the planner's
#: state keys, or a maker(index, num_states, key) -> factor | None called for every state
ExtraFactor = Union[Family, gtsam.NonlinearFactor, PerStateFactorMaker]


@dataclass(frozen=True)
class Target:
    """A start / goal / via point: kind "joint" (value (n,) rad) or "position" (value (3,) m)."""

    kind: str
    value: np.ndarray


@dataclass(frozen=True)
class Request:
    """A validated planning request (what :func:`build` was asked), with the start resolved:
    q_start (n,) [rad], start_position (3,) [m], vias [(index, Target)]."""

    start: Target
    goal: Target | None
    vias: tuple[tuple[int, Target], ...]
    q_start: np.ndarray
    start_position: np.ndarray
    start_ik_error: float


# ---------------------------------------------------------------------------------- inputs
def _check_prior(prior: Any) -> None:
    for attr in ("Phi", "u", "Q", "mean0", "cov0", "mean", "dt"):
        if not hasattr(prior, attr):
            raise InvalidParameterError(f"prior: expected a clamp.WorkspacePrior, "
                                        f"got {type(prior).__name__} without '{attr}'")
    if np.shape(prior.Phi)[1:] != (6, 6):
        raise ShapeError(f"prior: expected a workspace prior over x = [p, v] (D = 6), "
                         f"got Phi of shape {np.shape(prior.Phi)}")


def _check_robot(robot: Any) -> None:
    for attr in ("n", "ee_kinematics", "sphere_centres", "fk", "ik", "ik_trajectory"):
        if not hasattr(robot, attr):
            raise InvalidParameterError(f"robot: expected a robots.Robot, got "
                                        f"{type(robot).__name__} without '{attr}'")


def _as_config(config: Any) -> PlannerConfig:
    if config is None:
        return PlannerConfig()
    if not isinstance(config, PlannerConfig):
        raise InvalidParameterError(f"config: expected a clamp.PlannerConfig (e.g. "
                                    f"PlannerConfig().with_(sigma_obs=0.005)), got "
                                    f"{type(config).__name__}")
    return config.validate()


def as_scene(scene: Any) -> Any:
    """A scenes.Scene from None, a Scene, an obstacle, a list of obstacles or a scene file path."""
    from scenes import Scene
    from scenes.obstacles import Obstacle
    if scene is None or isinstance(scene, Scene):
        return scene
    if isinstance(scene, Obstacle):
        return Scene([scene])
    if isinstance(scene, (str, Path)):
        return Scene.load(scene)
    if isinstance(scene, (list, tuple)) and all(isinstance(o, Obstacle) for o in scene):
        return Scene(list(scene))
    raise InvalidParameterError(f"scene: expected a scenes.Scene, an obstacle, a list of "
                                f"obstacles, a scene file path or None, got {type(scene).__name__}")


def as_target(value: Any, name: str, n: int) -> Target:
    """A joint configuration (n,) or an end-effector position (3,) (joint wins when n == 3)."""
    size = np.size(value) if np.ndim(value) == 1 else -1
    if size == n:
        return Target("joint", as_array(value, name, (n,)))
    if size == 3:
        return Target("position", as_array(value, name, (3,)))
    raise ShapeError(f"{name}: expected a joint configuration ({n},) or an end-effector "
                     f"position (3,), got shape {np.shape(value)}")


def _via_targets(via_points: Sequence[tuple[int, Any]], T: int,
                 n: int) -> tuple[tuple[int, Target], ...]:
    out = []
    for k, item in enumerate(via_points):
        if not isinstance(item, (tuple, list)) or len(item) != 2:
            raise ShapeError(f"via_points[{k}]: expected a pair (index, position (3,) or "
                             f"configuration ({n},)), got {item!r}")
        index = as_count(item[0], f"via_points[{k}] index", minimum=0)
        if index >= T:
            raise InvalidParameterError(f"via_points[{k}] index: expected 0 <= index < {T}, "
                                        f"got {index}")
        out.append((index, as_target(item[1], f"via_points[{k}] target", n)))
    return tuple(out)


def _has_obstacles(scene: Any) -> bool:
    return scene is not None and len(getattr(scene, "obstacles", ())) > 0


def _request(prior: Any, robot: Any, start: Any, goal: Any, via_points: Sequence,
             config: PlannerConfig, q_start: np.ndarray | None = None) -> Request:
    n, T = robot.n, prior.Phi.shape[0] + 1
    if start is None:
        raise InvalidParameterError(f"start: expected a joint configuration ({n},) or an "
                                    "end-effector position (3,), got None")
    start_target = as_target(start, "start", n)
    goal_target = None if goal is None else as_target(goal, "goal", n)
    vias = _via_targets(via_points, T, n)
    ik_error = 0.0
    if q_start is not None:
        q_start = as_array(q_start, "q_start", (n,))
    elif start_target.kind == "joint":
        q_start = start_target.value
    else:
        checks = config.checks
        ik = robot.ik(start_target.value, tol=min(checks.ik_tolerance, checks.start_tolerance))
        q_start, ik_error = np.asarray(ik.q, dtype=float), float(ik.error)
    position = start_target.value if start_target.kind == "position" else robot.fk(q_start)
    return Request(start_target, goal_target, vias, q_start, position, ik_error)


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


def distance_query(scene: Any, config: PlannerConfig, sdf: Any = None) -> Callable | None:
    """The signed-distance query the obstacle family uses: ``sdf.query`` when given, else the
    scene's (exact for primitives, a grid cached by the scene otherwise); None without
    obstacles or with obstacle factors off."""
    if not config.model.obstacle_factors or not _has_obstacles(scene):
        return None
    if sdf is not None:
        return sdf.query
    return scene.distance_query(config.model.sdf_cell_size)


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
    for k, extra in enumerate(extra_factors):
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
    problem, _, _ = _build(prior, robot, as_scene(scene), start, goal, via_points,
                           extra_factors, _as_config(config), sdf, initial)
    return problem


def _build(prior, robot, scene, start, goal, via_points, extra_factors, config, sdf, initial,
           request: Request | None = None) -> tuple[PlanningProblem, Request, Initialisation]:
    _check_prior(prior)
    _check_robot(robot)
    T, dt = prior.Phi.shape[0] + 1, float(prior.dt)
    request = request or _request(prior, robot, start, goal, via_points, config)
    extra_families, foreign = _extras(extra_factors, T)
    families = _families(prior, robot, request, config, distance_query(scene, config, sdf))
    init = (_initialise(prior, robot, request, config) if initial is None
            else warm_start(robot, initial, T, dt))
    problem = PlanningProblem(robot, T, families + extra_families, foreign, init.theta)
    return problem, request, init


# ---------------------------------------------------------------------------------- checking
def sphere_clearance(robot: Any, scene: Any, q: np.ndarray) -> np.ndarray:
    """Exact clearance (T, S) [m] of every collision sphere at q (T, n); +inf without obstacles."""
    centres, _ = robot.sphere_centres(q)
    if not _has_obstacles(scene):
        return np.full(centres.shape[:2], np.inf)
    return scene.distance(centres) - np.asarray(robot.spheres.radii)


def _failed(prior: Any, robot: Any, q: np.ndarray, reasons: list[str], t0: float,
            start_error: float, config: PlannerConfig) -> PlanResult:
    kin = robot.ee_kinematics(q, np.zeros_like(q), jacobians=False)
    return PlanResult(q=q, qdot=np.zeros_like(q), ee_path=kin.position,
                      ee_velocity=kin.velocity, time=np.asarray(prior.time, dtype=float),
                      timings={"build": 0.0, "optimize": 0.0, "marginals": 0.0,
                               "total": time.perf_counter() - t0},
                      iterations=0, initial_error=float("nan"), final_error=float("nan"),
                      family_errors={}, collision_cost=float("nan"),
                      min_clearance=float("nan"), start_error=start_error, goal_error=None,
                      log_likelihood=float("nan"), success_probability=0.0,
                      within_limits=bool(np.all(robot.within_limits(q))), success=False,
                      reasons=reasons, initialisation=config.optimizer.initialisation,
                      optimizer=config.optimizer.optimizer, stop_reason="not started")


def _start_problems(robot: Any, scene: Any, request: Request, config: PlannerConfig) -> list[str]:
    start = request.start
    if start.kind == "position" and request.start_ik_error > config.checks.start_tolerance:
        return [f"start position {np.round(start.value, 4).tolist()} is out of reach (IK "
                f"error {request.start_ik_error * 1000:.1f} mm)"]
    reasons = []
    if _has_obstacles(scene):
        if start.kind == "position" and float(scene.distance(start.value)) < 0:
            reasons.append("start position is inside an obstacle")
        clearance = sphere_clearance(robot, scene, request.q_start[None])
        if np.min(clearance) < 0:
            reasons.append(f"start configuration is in collision (clearance "
                           f"{np.min(clearance) * 1000:.1f} mm)")
    return reasons


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
          covariance) -> PlanResult:
    t0 = time.perf_counter()
    config = _as_config(config)
    _check_prior(prior)
    _check_robot(robot)
    scene = as_scene(scene)
    request = _request(prior, robot, start, goal, via_points, config)
    T = prior.Phi.shape[0] + 1
    reasons = _start_problems(robot, scene, request, config)
    if reasons:
        return _failed(prior, robot, np.repeat(request.q_start[None], T, axis=0), reasons, t0,
                       request.start_ik_error, config)
    problem, request, init = _build(prior, robot, scene, start, goal, via_points, extra_factors,
                                    config, sdf, initial, request)
    t_opt = time.perf_counter()
    out = optimize(problem, config)
    t_cov = time.perf_counter()
    state_cov = ee_cov = None
    floor = 0.0
    if covariance and problem.banded:
        state_cov, ee_cov, floor = plan_covariances(problem, out.theta)
    t_end = time.perf_counter()
    timings = {"build": t_opt - t0, "optimize": t_cov - t_opt, "marginals": t_end - t_cov,
               **out.timings}
    result = _evaluate(prior, robot, scene, problem, request, out, config, timings)
    result.initial_q = init.q
    result.state_covariance, result.ee_covariance = state_cov, ee_cov
    result.covariance_floor = floor
    result.timings["total"] = time.perf_counter() - t0
    return result


def _evaluate(prior: Any, robot: Any, scene: Any, problem: PlanningProblem, request: Request,
              out: Optimized, config: PlannerConfig, timings: dict[str, float]) -> PlanResult:
    """Metrics and success checks of an optimised plan."""
    n, checks = robot.n, config.checks
    q, qdot = out.theta[:, :n], out.theta[:, n:]
    x, _ = problem.window(out.theta).workspace()
    position = x[:, :3]
    families = problem.family_errors(out.theta)
    clearance = float(np.min(sphere_clearance(robot, scene, q)))
    start = request.start
    start_error = float(np.linalg.norm((position[0] if start.kind == "position" else q[0])
                                       - start.value))
    goal_error = None
    if request.goal is not None:
        reached = position[-1] if request.goal.kind == "position" else q[-1]
        goal_error = float(np.linalg.norm(reached - request.goal.value))
    via_errors = [float(np.linalg.norm((position[i] if t.kind == "position" else q[i]) - t.value))
                  for i, t in request.vias]
    within = bool(np.all(robot.within_limits(q, checks.limit_tolerance)) and np.all(
        np.abs(qdot) <= np.asarray(robot.velocity_limits) + checks.velocity_tolerance))
    log_likelihood = float(prior.log_likelihood(x, initial=False))
    probability = float(prior.success_probability(x)) if hasattr(prior, "success_probability") \
        else float("nan")

    reasons = []
    if not np.isfinite(out.final_error):
        reasons.append("optimisation diverged (non-finite error)")
    if start_error > checks.start_tolerance:
        reasons.append(f"start error {start_error:.4g} exceeds {checks.start_tolerance:.4g}")
    if goal_error is not None and goal_error > checks.goal_tolerance:
        reasons.append(f"goal error {goal_error:.4g} exceeds {checks.goal_tolerance:.4g}")
    for (index, _), error in zip(request.vias, via_errors):
        if error > checks.goal_tolerance:
            reasons.append(f"via point at state {index}: error {error:.4g} exceeds "
                           f"{checks.goal_tolerance:.4g}")
    if clearance < 0:
        reasons.append(f"collision: minimum clearance {clearance * 1000:.1f} mm")
    if not within:
        reasons.append("joint position or velocity limits violated")
    return PlanResult(q=q, qdot=qdot, ee_path=position, ee_velocity=x[:, 3:],
                      time=np.asarray(prior.time, dtype=float), timings=timings,
                      iterations=out.iterations, initial_error=out.initial_error,
                      final_error=out.final_error, family_errors=families,
                      collision_cost=families.get("obstacle", 0.0), min_clearance=clearance,
                      start_error=start_error, goal_error=goal_error,
                      log_likelihood=log_likelihood, success_probability=probability,
                      within_limits=within, success=not reasons, reasons=reasons,
                      initialisation=config.optimizer.initialisation, trials=out.trials,
                      optimizer=out.optimizer, stop_reason=out.stop_reason,
                      via_errors=via_errors)
