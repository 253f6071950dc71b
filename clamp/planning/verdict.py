"""The verdict of a plan: what was asked of it (start, goal, via points, clearance, limits,
constraint families such as orientation) checked on the optimised trajectory, with the figures
behind every reason; and the early failures (start out of reach, inside an obstacle or in
collision) that stop before planning. Clearance is measured on the
robot's own collision geometry (:mod:`clamp.planning.clearance`), never on the optimiser's spheres.
"""
from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from clamp.planning.clearance import check_clearance
from clamp.config import PlannerConfig
from clamp.planning.limit_report import limit_violations
from clamp.errors import ClampTypeError
from clamp.factors.joint_limits import LIMIT_TOLERANCE
from clamp.factors.self_collision import CLEARANCE_TOLERANCE
from clamp.factors import (JointLimitFamily, ObstacleFamily, SelfCollisionFamily,
                           SkillOrientationFamily, SkillTubeFamily,
                           declared_families, lazy_families)
from clamp.planning.pipeline import (Model, Posterior, Solution, check_context, ordered_checks,
                                     run_checks)
from clamp.planning.request import Request, as_scene, has_obstacles
from clamp.planning.result import PlanInputs, PlanResult
from clamp.planning.targets import inside_obstacle
from clamp.prior import so3
from clamp.validation import as_scalar
from robots.contact import collision_reason, describe_contact
from robots.self_collision import self_collision_report
from skillplan.validation import as_instance


def sphere_clearance(robot: Any, scene: Any, q: np.ndarray) -> np.ndarray:
    """Exact clearance (T, S) [m] of every collision sphere at q (T, n); +inf without obstacles
    (``scene``: anything :func:`clamp.plan` accepts as one)."""
    scene = as_scene(scene)
    centres, _ = robot.sphere_centres(q)
    if not has_obstacles(scene):
        return np.full(centres.shape[:2], np.inf)
    return scene.distance(centres) - np.asarray(robot.spheres.radii)


def failed_result(prior: Any, robot: Any, q: np.ndarray, reasons: list[str], t0: float,
            start_error: float, config: PlannerConfig) -> PlanResult:
    kin = robot.ee_kinematics(q, np.zeros_like(q), jacobians=False)
    return PlanResult(q=q, qdot=np.zeros_like(q), ee_path=kin.position,
                      ee_velocity=kin.velocity, time=np.asarray(prior.time, dtype=float),
                      timings={"build": 0.0, "optimize": 0.0, "marginals": 0.0,
                               "total": time.perf_counter() - t0},
                      iterations=0, initial_error=float("nan"), final_error=float("nan"),
                      family_errors={}, collision_cost=float("nan"),
                      min_clearance=float("nan"), start_error=start_error, goal_error=None,
                      log_likelihood=float("nan"), plausibility=float("nan"),
                      within_limits=bool(np.all(robot.within_limits(q))), success=False,
                      reasons=reasons, initialisation=config.optimizer.initialisation,
                      optimizer=config.optimizer.optimizer, stop_reason="not started")


def start_problems(robot: Any, scene: Any, request: Request, config: PlannerConfig) -> list[str]:
    start = request.start
    if start.kind == "position" and request.start_ik_error > config.checks.start_tolerance:
        return [f"start position {np.round(start.value, 4).tolist()} is out of reach (IK "
                f"error {request.start_ik_error * 1000:.1f} mm)"]
    reasons = []
    if start.kind == "joint":
        reasons += limit_violations(robot, request.q_start[None], None, LIMIT_TOLERANCE,
                                    what="start configuration")
    # collision and depth are exact at any tolerance: the check's (a clearance far from zero
    # then needs no exact mesh query)
    own = self_collision_report(robot, request.q_start[None], tolerance=CLEARANCE_TOLERANCE)
    if own.collision:
        reasons.append("start configuration is in " + own.reason)
    if has_obstacles(scene):
        inside = inside_obstacle(scene, "start", start)
        if inside:
            reasons.append(inside)
        required = config.checks.min_clearance
        report = check_clearance(robot, scene, request.q_start[None], margin=required)
        if report.fault is not None:
            reasons.append(collision_reason(report))
        elif report.collision and report.min_distance < 0.0:
            reasons.append("start configuration is in collision: "
                           + describe_contact(report.nearest, report.geometry))
        elif report.collision:
            reasons.append(f"start configuration has clearance {report.min_distance * 1e3:.1f} mm, "
                           f"below the required min_clearance {required * 1e3:.1f} mm: "
                           + describe_contact(report.nearest, report.geometry))
    return reasons


def rotation_errors(robot: Any, request: Request, q: np.ndarray
                    ) -> tuple[float | None, list[float | None]]:
    """The angle [rad] between the hand's rotation and the goal pose's at the last state (None
    without a goal rotation), and at every via point (None where it gives no rotation), for
    joint positions q (T, n)."""
    def error(index: int, target: Any) -> float | None:
        if target is None or target.rotation is None:
            return None
        return float(so3.angle_between(robot.ee_rotation(q[index])[0], target.rotation))
    return error(len(q) - 1, request.goal), [error(i, t) for i, t in request.vias]


def _length(value: float, target: Any) -> str:
    """An error or tolerance of a target in its unit: mm for a position, rad for joints."""
    return f"{value * 1e3:.4g} mm" if target.kind == "position" else f"{value:.4g} rad"


def plan_inputs(model: Model) -> PlanInputs:
    """What ``model`` was asked, for ``PlanResult.inputs`` (:func:`clamp.replan` plans it again):
    start, goal and via points as the request's validated values."""
    request = model.request
    return PlanInputs(model.prior, model.robot, model.scene, request.start.value,
                      None if request.goal is None else request.goal.given(),
                      tuple((index, target.given()) for index, target in request.vias),
                      model.extra_factors, model.config, model.sdf, model.model_prior,
                      model.free_plan)


def budget_reason(search: dict[str, Any]) -> str:
    """The reason a failed plan gives when the search's budget ended it (``PlanResult.search``)."""
    limit = search.get("limit")
    spent = (f"{search['work']} of {limit:.0f} units of work" if limit is not None
             else "its deadline")
    return (f"search ended by its budget ({spent}) with {len(search['left'])} strategies left: "
            + ", ".join(search["left"]))


def evaluate(model: Model, solution: Solution, posterior: Posterior,
             timings: dict[str, float] | None = None, started: float | None = None
             ) -> PlanResult:
    """The complete :class:`~clamp.planning.result.PlanResult` of ``solution`` (metrics, success checks
    with their reasons, ``posterior``'s covariances and faults, the model's initial trajectory
    and inputs, the constraint loop's attempts) for ``model``, made in one go: timings [s] of
    the stages before it (None: none) plus "total", from ``started`` (``time.perf_counter()``
    when the plan began; None: when the verdict began) until the result is made."""
    started = time.perf_counter() if started is None else as_scalar(started, "started")
    timings = {} if timings is None else as_instance(
        timings, "timings", dict, "a dict of stage name -> seconds, or None", ClampTypeError)
    as_instance(model, "model", Model, "a clamp.planning.pipeline.Model", ClampTypeError)
    as_instance(solution, "solution", Solution, "a clamp.planning.pipeline.Solution", ClampTypeError)
    as_instance(posterior, "posterior", Posterior, "a clamp.planning.pipeline.Posterior",
                ClampTypeError)
    prior, robot, request, config = model.prior, model.robot, model.request, model.config
    problem, out = solution.problem, solution.optimum
    n, checks = robot.n, config.checks
    q, qdot = out.theta[:, :n], out.theta[:, n:]
    x, _ = problem.window(out.theta).workspace()
    position = x[:, :3]
    families = problem.family_errors(out.theta)
    # every constraint's check of the final plan: the solve's records reused, the others made
    # here (after a collision, the checks the solve skipped; the skill's score)
    checkers = ordered_checks([*problem.families, *lazy_families(),
                               *(cls for cls in declared_families() if cls.always_checked)])
    records = run_checks(check_context(model, final=True), checkers, out.theta,
                         {record.name: record for record in solution.checks})
    found = {record.name: record for record in records}
    report = found[ObstacleFamily.name].report if ObstacleFamily.name in found else None
    self_report = found[SelfCollisionFamily.name].report
    limits = list(found[JointLimitFamily.name].reasons)
    skill = found[SkillTubeFamily.name].report
    turned = found.get(SkillOrientationFamily.name)
    violations = {record.name: record.amount for record in records if record.listed}
    clearance = math.inf if report is None else float(report.min_distance)
    start = request.start
    start_error = float(np.linalg.norm((position[0] if start.kind == "position" else q[0])
                                       - start.value))
    goal_error = None
    if request.goal is not None:
        reached = position[-1] if request.goal.kind == "position" else q[-1]
        goal_error = float(np.linalg.norm(reached - request.goal.value))
    via_errors = [float(np.linalg.norm((position[i] if t.kind == "position" else q[i]) - t.value))
                  for i, t in request.vias]
    goal_rotation_error, via_rotation_errors = rotation_errors(robot, request, q)
    log_likelihood = float(prior.log_likelihood(x, initial=False))

    reasons = list(posterior.faults)
    if not np.isfinite(out.final_error):
        reasons.append("optimisation diverged (non-finite error)")
    if start_error > checks.start_tolerance:
        reasons.append(f"start error {_length(start_error, start)} exceeds "
                       f"{_length(checks.start_tolerance, start)}")
    if goal_error is not None and goal_error > checks.goal_tolerance:
        reasons.append(f"goal error {_length(goal_error, request.goal)} exceeds "
                       f"{_length(checks.goal_tolerance, request.goal)}")
    for (index, target), error in zip(request.vias, via_errors):
        if error > checks.via_tolerance:
            reasons.append(f"via point at state {index}: error {_length(error, target)} exceeds "
                           f"{_length(checks.via_tolerance, target)}")
    named = [("goal", goal_rotation_error)] + [
        (f"via point at state {index}", error)
        for (index, _), error in zip(request.vias, via_rotation_errors)]
    for name, error in named:
        if error is not None and error > checks.rotation_tolerance:
            reasons.append(f"{name}: the hand's rotation {np.degrees(error):.3g} deg from the "
                           f"pose's, limit {np.degrees(checks.rotation_tolerance):.3g} deg")
    for record in records:                # in check order: collision, self-collision,
        reasons += record.reasons         # limits, constraint families, the skill
    if reasons and solution.search.get("budget_ended"):
        reasons.append(budget_reason(solution.search))
    return PlanResult(q=q, qdot=qdot, ee_path=position, ee_velocity=x[:, 3:],
                      time=np.asarray(prior.time, dtype=float),
                      iterations=out.iterations, initial_error=out.initial_error,
                      final_error=out.final_error, family_errors=families,
                      collision_cost=families.get("obstacle", 0.0), min_clearance=clearance,
                      start_error=start_error, goal_error=goal_error,
                      log_likelihood=log_likelihood, plausibility=skill.plausibility,
                      skill={**skill.to_dict(), "reference": model.reference_name,
                             **({} if turned is None or turned.report is None
                                else turned.report.to_dict())},
                      goal_rotation_error=goal_rotation_error,
                      via_rotation_errors=via_rotation_errors,
                      self_clearance=float(self_report.min_distance),
                      fixed_overlaps=[] if report is None else list(report.fixed_overlaps),
                      self_contact=None if self_report.nearest is None
                      else self_report.nearest.to_dict(),
                      within_limits=not limits, success=not reasons, reasons=reasons,
                      initialisation=config.optimizer.initialisation, trials=out.trials,
                      optimizer=out.optimizer,
                      # a plan that violates what it was asked to meet never reports convergence
                      stop_reason="infeasible" if reasons and out.stop_reason == "converged"
                      else out.stop_reason,
                      via_errors=via_errors, violations=violations,
                      collision_geometry=None if report is None else report.geometry,
                      nearest_contact=None if report is None or report.nearest is None
                      else report.nearest.to_dict(),
                      initial_q=model.initialisation.q, attempts=[dict(a) for a in solution.attempts],
                      search=dict(solution.search),
                      state_covariance=posterior.state_covariance,
                      ee_covariance=posterior.ee_covariance, covariance_floor=posterior.floor,
                      inputs=plan_inputs(model), problem=problem,
                      timings={**timings, "total": time.perf_counter() - started})
