"""The stages of a plan, each an immutable record made once from the one before:

request (:class:`clamp.planning.request.Request`, :func:`clamp.planning.request.make_request`: the caller's
start, goal and via points validated and the start resolved) -> :class:`Model` (:func:`model`:
the planning problem and what it was built from) -> :class:`Solution` (:func:`solve`: the
optimum, collision-free as a constraint, and the real-geometry checks of it) ->
:class:`Posterior` (:func:`posterior`: the Laplace covariances at the optimum) -> the verdict
(:func:`clamp.planning.verdict.evaluate`: the complete :class:`clamp.PlanResult`).

:func:`clamp.plan` runs them in turn; :func:`clamp.replan` runs them with the previous plan's
start configuration, conditioned prior and trajectory. A caller may run them by hand, e.g. to
inspect ``model(...).problem.graph()`` before solving.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from clamp.planning.assembly import (ExtraFactor, configured_initialisation, distance_query,
                            given_initialisation, planner_families, split_extras,
                            tied_to_free_plan, without_family)
from clamp.planning.clearance import check_clearance, contact_obstacle
from clamp.planning.reference import planning_prior, skill_reference
from clamp.config import PlannerConfig
from clamp.optim.constrained import Candidate, Feasibility, Judge, Progress, solve_constrained
from clamp.planning.detours import detour_restarts
from clamp.errors import ClampTypeError, InvalidParameterError, ShapeError
from clamp.factors import ObstacleFamily, PostureFamily, SelfCollisionFamily, SkillTubeFamily
from clamp.planning.initialisation import Initialisation
from clamp.optim.optimizers import Optimized
from clamp.graph.problem import PlanningProblem
from clamp.config import as_config
from clamp.planning.request import Request, as_extras, as_scene, check_robot
from clamp.prior.linear_gaussian import check_prior
from clamp.prior.skill import TUBE_RATIO, SkillRegion, skill_checks
from clamp.optim.solver import WarmStart
from clamp.planning.targets import violated_families
from clamp.optim.uncertainty import plan_covariances
from clamp.validation import as_bool
from robots.collision_check import CollisionReport
from robots.self_collision import SelfCollisionReport, self_collision_report
from skillplan.validation import as_instance

#: configurations checked between two states by the self-collision hinges (a count; see
#: docs/decisions.md#self_collision_between)
SELF_COLLISION_BETWEEN = 8
#: [m] the self-collision check's tolerance on a clear plan's clearance (collisions and depths
#: exact; see docs/decisions.md#self_clearance_tolerance)
SELF_CLEARANCE_TOLERANCE = 0.01


@dataclass(frozen=True)
class Model:
    """What is solved: ``problem`` (:class:`~clamp.graph.problem.PlanningProblem` over the T joint
    states [q, qdot] (T, 2n), its GTSAM graph ``problem.graph()``, initial values
    ``problem.initial``) for ``request``; ``prior``: the learned workspace prior;
    ``model_prior``: it conditioned on the request's targets (the prior the families use);
    ``reference``: where the skill goes for the request
    (:func:`clamp.planning.reference.skill_reference`);
    ``initialisation``: the initial trajectory (q, qdot (T, n), path (T, 3) [m]) before the
    posture tie; ``scene`` (scenes.Scene or None), ``config``; ``extra_factors`` and ``sdf`` as
    the caller gave them."""

    prior: Any
    problem: PlanningProblem
    request: Request
    initialisation: Initialisation
    model_prior: Any
    reference: Any
    scene: Any
    config: PlannerConfig
    extra_factors: tuple = ()
    sdf: Any = None

    @property
    def robot(self) -> Any:
        """The robot planned for (robots.Robot, n joints)."""
        return self.problem.robot


@dataclass(frozen=True)
class Solution:
    """The optimum of a :class:`Model`: ``optimum`` (:class:`~clamp.optim.optimizers.Optimized`:
    theta (T, 2n), iterations, errors [nats], stop reason, phase timings [s]); ``problem``: the
    problem it optimises at the end (the model's with the constraint families' final shifts and
    noise, the self-collision hinges when they joined, without the posture tie when the untied
    restart won: the graph a user gets, ``PlanResult.problem``); ``report``: the obstacle check on the
    robot's collision geometry (None when the model has no obstacle hinges); ``self_report``:
    the self-collision check; ``attempts``: the constrained solve's solves (dicts, see
    ``PlanResult.attempts``)."""

    optimum: Optimized
    problem: PlanningProblem
    report: CollisionReport | None
    self_report: SelfCollisionReport
    attempts: tuple[dict[str, Any], ...]


@dataclass(frozen=True)
class Posterior:
    """The Laplace posterior at a :class:`Solution`'s optimum: ``state_covariance`` (T, 2n, 2n)
    and ``ee_covariance`` (T, 3, 3) [m^2] (None when not asked for or not computable: GTSAM
    optimizer problems, a fault); ``floor`` [1/rad^2] information added to every coordinate
    (0.0: exact; :mod:`clamp.optim.uncertainty`); ``faults``: why it failed (reasons for the verdict)."""

    state_covariance: np.ndarray | None = None
    ee_covariance: np.ndarray | None = None
    floor: float = 0.0
    faults: tuple[str, ...] = ()


# ------------------------------------------------------------------------------------ model
def model(prior: Any, robot: Any, scene: Any, request: Request, config: PlannerConfig | None,
          extra_factors: Sequence[ExtraFactor] = (), sdf: Any = None,
          initial: np.ndarray | None = None, *, model_prior: Any = None) -> Model:
    """The :class:`Model` of ``request`` (from :func:`clamp.planning.request.make_request` with the same
    prior, robot and config): the learned ``prior`` conditioned on the request's targets
    (``model_prior`` when the caller already has it, e.g. :func:`clamp.replan` with unchanged
    targets), the planner's families and ``extra_factors`` (see :data:`ExtraFactor`), the
    initialisation (``initial``: joint positions (T, n) or states (T, 2n) instead of the
    configured one) and, with obstacles, the tie to the free plan's posture. Other arguments as
    for :func:`clamp.build`. Raises ClampError subclasses on bad input."""
    check_prior(prior, workspace=True)
    check_robot(robot)
    scene, config = as_scene(scene), as_config(config)
    as_instance(request, "request", Request, "a clamp.planning.request.Request (from make_request)",
                ClampTypeError)
    if np.shape(request.q_start) != (robot.n,):
        raise ShapeError(f"request: expected a request for a robot with {robot.n} joints, got "
                         f"q_start of shape {np.shape(request.q_start)}")
    if model_prior is not None and np.shape(getattr(model_prior, "Phi", None)) != np.shape(prior.Phi):
        raise ShapeError(f"model_prior: expected a workspace prior over the same "
                         f"{prior.Phi.shape[0] + 1} states as prior (Phi {np.shape(prior.Phi)}), "
                         f"got {type(model_prior).__name__} with Phi of shape "
                         f"{np.shape(getattr(model_prior, 'Phi', None))}")
    return build_model(prior, robot, scene, request, config, tuple(as_extras(extra_factors)), sdf,
                       initial, model_prior=model_prior)


def build_model(prior: Any, robot: Any, scene: Any, request: Request, config: PlannerConfig,
                extra_factors: tuple[ExtraFactor, ...] = (), sdf: Any = None,
                initial: np.ndarray | None = None, *, model_prior: Any = None) -> Model:
    """:func:`model` on checked inputs: ``request`` made by :func:`make_request` for this prior,
    robot and config (the validation at the boundary), ``scene`` a scenes.Scene or None,
    ``extra_factors`` checked by :func:`as_extras`. What :func:`clamp.plan` runs."""
    T, dt = prior.Phi.shape[0] + 1, float(prior.dt)
    extra_families, foreign = split_extras(extra_factors, T)
    if model_prior is None:                       # the prior conditioned on the targets
        model_prior = planning_prior(prior, robot, request, config)
    reach = config.model.epsilon + float(np.max(robot.spheres.radii, initial=0.0))
    families = planner_families(model_prior, robot, request, config,
                                distance_query(scene, config, sdf, reach))
    init = (configured_initialisation(model_prior, robot, request, config) if initial is None
            else given_initialisation(robot, initial, T, dt))
    problem = PlanningProblem(robot, T, families + extra_families, foreign, init.theta)
    if config.model.posture_sigma > 0 and problem.has(ObstacleFamily.name):
        problem = tied_to_free_plan(problem, config, keep_initial=initial is not None)
    reference = skill_reference(prior, robot, request, config, model_prior)
    return Model(prior, problem, request, init, model_prior, reference, scene, config,
                 extra_factors, sdf)


# ------------------------------------------------------------------------------------ solve
def _restarts(model: Model) -> Callable[[Progress], Iterable[Candidate]]:
    """Other starts when the problem as built fails its checks (see :mod:`clamp.optim.constrained`),
    all without the posture tie (the free plan's posture is what led into the obstacles; a
    tied detour is pulled back into it): the configured initialisation, detours of the initial
    path around the obstacle nearest the closest optimum, a straight line in joint space (see
    docs/decisions.md#untied-restarts)."""
    prior, robot, scene, request, config = (model.prior, model.robot, model.scene,
                                            model.request, model.config)
    problem, init = model.problem, model.initialisation
    untied = without_family(problem, PostureFamily.name, init.theta)

    def generate(progress: Progress) -> Iterable[Candidate]:
        if problem.has(PostureFamily.name):
            yield Candidate("untied", untied)
        report = progress.closest.reports.get(ObstacleFamily.name) if progress.closest else None
        if report is not None and report.nearest is not None:
            for name, theta in detour_restarts(
                    robot, init.path, request.q_start, float(prior.dt),
                    contact_obstacle(robot, scene, report.nearest), config.model.epsilon,
                    report.nearest.index, config.checks.ik_tolerance):
                yield Candidate(name, untied.with_families(untied.families, theta))
        if config.optimizer.initialisation != "straight_line":
            line = configured_initialisation(prior, robot, request,
                                             config.with_(initialisation="straight_line"))
            yield Candidate("straight_line", untied.with_families(untied.families, line.theta))
    return generate


def _judge(model: Model) -> Judge:
    """The verdict's checks of an optimum theta (T, 2n), as the constrained solve needs them:
    obstacle collision on the robot's collision geometry (first: the others only run on a clear
    plan), the joint limits and constraint families (:func:`clamp.planning.targets.violated_families`),
    self-collision, and with obstacles the skill checks of a plan that meets all of these: one
    that leaves the skill's tube violates the ``skill_tube`` constraint (whose hinges then join,
    :class:`~clamp.factors.SkillTubeFamily`), one that does not complete the skill is not
    accepted (another start is tried)."""
    prior, robot, scene, request, config = (model.prior, model.robot, model.scene,
                                            model.request, model.config)
    families, obstacles = model.problem.families, model.problem.has(ObstacleFamily.name)
    time_ = np.asarray(prior.time, dtype=float)

    def judge(theta: np.ndarray) -> Feasibility:
        q, reports, clearance = theta[:, :robot.n], {}, math.inf
        if obstacles:
            report = check_clearance(robot, scene, q, time_)
            reports[ObstacleFamily.name], clearance = report, float(report.min_distance)
            if report.collision:
                return Feasibility((ObstacleFamily.name,), True, reports, clearance)
        violated = violated_families(families, robot, theta, config)
        own = self_collision_report(robot, q, time_, tolerance=SELF_CLEARANCE_TOLERANCE)
        reports[SelfCollisionFamily.name] = own
        if own.collision:
            violated.append(SelfCollisionFamily.name)
        accepted = True
        if obstacles and not violated:
            skill = skill_checks(prior, model.reference, robot.fk(q), request.goal is not None,
                                 score=False)
            if not skill.within_tube:
                violated.append(SkillTubeFamily.name)
            accepted = skill.completed
        return Feasibility(tuple(violated), accepted, reports, clearance)
    return judge


def solve(model: Model, warm_start: WarmStart | None = None) -> Solution:
    """The :class:`Solution` of ``model``: optimised from ``model.problem.initial`` (the fast
    solver or the configured GTSAM optimizer; ``warm_start``: the fast solver's warm-start
    rule, for a start near the optimum) with every constraint inside one constrained solve
    (:func:`clamp.optim.constrained.solve_constrained`: an augmented Lagrangian on the constraint
    families, judged by the verdict's checks: obstacles on the robot's collision geometry,
    self-collision, whose hinges join when the plan collides with itself, limits, constraint
    families and, with obstacles, the skill, whose tube hinges join when the plan leaves it;
    restarts when the problem as built fails)."""
    as_instance(model, "model", Model, "a clamp.planning.pipeline.Model (from clamp.planning.pipeline.model)",
                ClampTypeError)
    if warm_start is not None:
        as_instance(warm_start, "warm_start", WarmStart, "a clamp.optim.solver.WarmStart or None",
                    ClampTypeError)
    robot, problem, m = model.robot, model.problem, model.config.model
    lazy = {SelfCollisionFamily.name: lambda: SelfCollisionFamily.for_robot(
                robot, range(problem.num_states - 1), m.self_collision_epsilon,
                m.self_collision_sigma, SELF_COLLISION_BETWEEN),
            SkillTubeFamily.name: lambda: SkillTubeFamily(
                np.asarray(model.reference.mean)[:, :3],
                TUBE_RATIO * SkillRegion.of(model.prior).tube, m.sigma_obs)}
    restarts = _restarts(model) if problem.has(ObstacleFamily.name) else (lambda _: ())
    # the tied problem: one solve, its rounds go to the untied restart (clamp.optim.constrained)
    solved = solve_constrained(problem, model.config, _judge(model), restarts, lazy, warm_start,
                               first_rounds=0 if problem.has(PostureFamily.name) else None)
    reports = solved.feasibility.reports
    own = reports.get(SelfCollisionFamily.name)
    if own is None:             # the chosen optimum collides with an obstacle: not yet checked
        own = self_collision_report(robot, solved.out.theta[:, :robot.n],
                                    np.asarray(model.prior.time, dtype=float),
                                    tolerance=SELF_CLEARANCE_TOLERANCE)
    return Solution(solved.out, solved.problem, reports.get(ObstacleFamily.name), own,
                    tuple(asdict(a) for a in solved.attempts))


# -------------------------------------------------------------------------------- posterior
def posterior(model: Model, solution: Solution, covariance: bool = True) -> Posterior:
    """The :class:`Posterior` at ``solution``'s optimum: the covariance of every joint state and
    end-effector position when ``covariance`` and the problem is the fast solver's (banded); a
    numerical failure (e.g. a time step of microseconds) is a fault of the plan, reported, not
    raised."""
    as_instance(model, "model", Model, "a clamp.planning.pipeline.Model", ClampTypeError)
    as_instance(solution, "solution", Solution, "a clamp.planning.pipeline.Solution (from solve)",
                ClampTypeError)
    if not as_bool(covariance, "covariance") or not solution.problem.banded:
        return Posterior()
    try:
        state_cov, ee_cov, floor = plan_covariances(solution.problem, solution.optimum.theta)
    except (InvalidParameterError, np.linalg.LinAlgError) as exc:
        # a fault of the plan's own numbers, not of the caller's input: the verdict says so
        return Posterior(faults=(f"posterior covariance failed: {exc}",))
    return Posterior(state_cov, ee_cov, floor)
