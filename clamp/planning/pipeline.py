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
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from clamp.planning.assembly import (ExtraFactor, configured_initialisation, distance_query,
                            free_plan, given_initialisation, planner_families, split_extras,
                            tied_to_free_plan)
from clamp.planning.clearance import check_clearance, pusher
from clamp.planning.reference import planning_prior, skill_reference
from clamp.config import PlannerConfig
from clamp.optim.constrained import Feasibility, Judge
from clamp.planning.search import Budget, search
from clamp.errors import ClampTypeError, InvalidParameterError, ShapeError
from clamp.factors import (CheckContext, ConstraintCheck, ObstacleFamily, SelfCollisionFamily,
                           lazy_families)
from clamp.planning.initialisation import Initialisation
from clamp.optim.optimizers import Optimized
from clamp.graph.problem import PlanningProblem
from clamp.config import as_config
from clamp.planning.request import Request, as_extras, as_scene, check_robot
from clamp.planning.time_scale import demonstrated_speed_config
from clamp.prior.linear_gaussian import check_prior
from clamp.optim.solver import WarmStart
from clamp.optim.uncertainty import plan_covariances
from clamp.validation import as_array, as_bool
from robots.collision_check import CollisionReport
from robots.self_collision import SelfCollisionReport
from skillplan.validation import as_instance

@dataclass(frozen=True)
class Model:
    """What is solved: ``problem`` (:class:`~clamp.graph.problem.PlanningProblem` over the T joint
    states [q, qdot] (T, 2n), its GTSAM graph ``problem.graph()``, initial values
    ``problem.initial``) for ``request``; ``prior``: the learned workspace prior;
    ``model_prior``: it conditioned on the request's targets (the prior the families use);
    ``reference``: where the skill goes for the request, the skill checks' reference
    (:func:`clamp.planning.reference.skill_reference`: the conditioned prior, or its workspace
    MAP under the caller's families that act on the hand's path), ``reference_name`` what it
    is, in words (``PlanResult.skill["reference"]``);
    ``initialisation``: the initial trajectory (q, qdot (T, n), path (T, 3) [m]) before the
    posture tie; ``scene`` (scenes.Scene or None), ``config``; ``extra_factors`` and ``sdf`` as
    the caller gave them; ``free_plan``: the free plan (T, 2n) the problem is tied to (None
    without the tie)."""

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
    reference_name: str = "prior conditioned on the targets"
    free_plan: np.ndarray | None = None

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
    ``PlanResult.attempts``); ``checks``: the records of every check the solve made of the
    optimum (:class:`clamp.factors.ConstraintCheck`; the verdict reuses them and makes only
    the others); ``search``: what the search spent (``PlanResult.search``: work, limit,
    unit, limit, budget_ended, the strategies left)."""

    optimum: Optimized
    problem: PlanningProblem
    report: CollisionReport | None
    self_report: SelfCollisionReport
    attempts: tuple[dict[str, Any], ...]
    checks: tuple[ConstraintCheck, ...] = ()
    search: dict[str, Any] = field(default_factory=dict)


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
          initial: np.ndarray | None = None, *, model_prior: Any = None,
          free: np.ndarray | None = None, free_start: np.ndarray | None = None) -> Model:
    """The :class:`Model` of ``request`` (from :func:`clamp.planning.request.make_request` with the same
    prior, robot and config): the learned ``prior`` conditioned on the request's targets
    (``model_prior`` when the caller already has it, e.g. :func:`clamp.replan` with unchanged
    targets), the planner's families and ``extra_factors`` (see :data:`ExtraFactor`), the
    initialisation (``initial``: joint positions (T, n) or states (T, 2n) instead of the
    configured one) and, with obstacles, the tie to the free plan's posture (``free``: that
    free plan (T, 2n) when known; ``free_start``: a guess (T, 2n) of it to solve it from; see
    :func:`build_model`).
    Other arguments as for :func:`clamp.build`. Raises ClampError subclasses on bad input."""
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
    T = prior.Phi.shape[0] + 1
    free = None if free is None else as_array(free, "free", (T, 2 * robot.n))
    if free_start is not None:
        free_start = as_array(free_start, "free_start", (T, 2 * robot.n))
    return build_model(prior, robot, scene, request, config, tuple(as_extras(extra_factors)), sdf,
                       initial, model_prior=model_prior, free=free, free_start=free_start)


def build_model(prior: Any, robot: Any, scene: Any, request: Request, config: PlannerConfig,
                extra_factors: tuple[ExtraFactor, ...] = (), sdf: Any = None,
                initial: np.ndarray | None = None, *, model_prior: Any = None,
                free: np.ndarray | None = None, free_start: np.ndarray | None = None) -> Model:
    """:func:`model` on checked inputs: ``request`` made by :func:`make_request` for this prior,
    robot and config (the validation at the boundary), ``scene`` a scenes.Scene or None,
    ``extra_factors`` checked by :func:`as_extras`. What :func:`clamp.plan` runs. With the tie
    to the free plan, :func:`clamp.replan` may give it: ``free`` (T, 2n), the free plan of
    this very request (the previous one's, when only the scene changed); or ``free_start``
    (T, 2n), a guess of it (the previous free plan moved to the new targets): the free plan is
    then solved from the guess (as configured), and the tied problem starts from
    ``initial`` moved by that solve's correction of the guess (free plan - ``free_start``):
    the previous plan follows its free plan (it is the new free plan where the previous plan
    was its free plan). The model's config is ``config`` for the speed the skill was
    demonstrated at (:func:`clamp.planning.time_scale.demonstrated_speed_config`)."""
    T, dt = prior.Phi.shape[0] + 1, float(prior.dt)
    config = demonstrated_speed_config(config, prior)
    extra_families, foreign = split_extras(extra_factors, T, robot)
    if model_prior is None:                       # the prior conditioned on the targets
        model_prior = planning_prior(prior, robot, request, config)
    reach = config.model.epsilon + float(np.max(robot.spheres.radii, initial=0.0))
    families = planner_families(model_prior, robot, request, config,
                                distance_query(scene, sdf, reach))
    init = (configured_initialisation(model_prior, robot, request, config) if initial is None
            else given_initialisation(robot, initial, T, dt))
    problem = PlanningProblem(robot, T, families + extra_families, foreign, init.theta)
    if config.model.posture_sigma > 0 and problem.has(ObstacleFamily.name):
        if free is None:
            free = free_plan(problem, config, free_start)
            if free_start is not None and initial is not None:
                problem = problem.with_families(problem.families,
                                                problem.initial + (free - free_start))
        problem = tied_to_free_plan(problem, config, initial is not None, free)
    else:
        free = None
    reference, reference_name = skill_reference(prior, robot, request, config, model_prior,
                                                extra_families)
    return Model(prior, problem, request, init, model_prior, reference, scene, config,
                 extra_factors, sdf, reference_name, free)


# ------------------------------------------------------------------------------------ solve
def check_context(model: Model, final: bool = False) -> CheckContext:
    """What the constraint families' checks (and the lazy families' makers) of ``model`` use
    (:class:`clamp.factors.CheckContext`); final: the verdict's (the skill scored)."""
    prior, robot, scene = model.prior, model.robot, model.scene
    time_ = np.asarray(prior.time, dtype=float)
    reference = np.asarray(model.reference.mean)[:, :3]
    epsilon = model.config.model.epsilon
    return CheckContext(robot, scene, prior, model.reference, model.config, time_,
                        model.problem.num_states, model.request.goal is not None,
                        model.problem.has(ObstacleFamily.name), tuple(model.problem.families),
                        clearance=lambda q: check_clearance(robot, scene, q, time_,
                                                            model.config.checks.min_clearance),
                        pusher=lambda path: pusher(scene, reference, path, epsilon), final=final)


def ordered_checks(checkers: Iterable[Any]) -> list[Any]:
    """Constraint families (instances or classes) with a check, one per name (the first),
    in check order (``check_rank``; their given order among equals)."""
    seen, out = set(), []
    for checker in checkers:
        if checker.role == "constraint" and checker.name not in seen:
            seen.add(checker.name)
            out.append(checker)
    return sorted(out, key=lambda checker: checker.check_rank)


def run_checks(context: CheckContext, checkers: Sequence[Any], theta: np.ndarray,
               done: Mapping[str, ConstraintCheck] | None = None) -> list[ConstraintCheck]:
    """The records of ``checkers`` (:func:`ordered_checks`) on theta (T, 2n), each check run at
    most once. In the solve a decisive violation (a collision) ends the run and a check
    ``only_if_clear`` runs only when every earlier one holds; the verdict (``context.final``)
    runs them all. ``done``: records already made of this theta, reused (completed by
    :meth:`clamp.factors.Family.for_verdict` when ``context.final``)."""
    records: list[ConstraintCheck] = []
    gated = not context.final
    for checker in checkers:
        if gated and checker.only_if_clear and any(r.violated for r in records):
            continue
        record = None if done is None else done.get(checker.name)
        if record is None:
            record = checker.check(context, theta)
        elif context.final:
            record = checker.for_verdict(context, theta, record)
        if record is None:
            continue
        records.append(record)
        if gated and record.violated and checker.decisive:
            break
    return records


def _judge(model: Model) -> Judge:
    """The verdict's checks of an optimum theta (T, 2n), as the constrained solve needs them:
    the own check of every constraint family the problem holds and of the lazy ones
    (:func:`clamp.factors.lazy_families`), in check order: obstacle collision on the robot's
    collision geometry (first: the others only run on a clear plan), self-collision, the joint
    limits, constraint families such as orientation, and with obstacles the skill checks of a
    plan that meets all of these: one that leaves the skill's tube violates the ``skill_tube``
    constraint (whose hinges then join, :class:`~clamp.factors.SkillTubeFamily`), one that does
    not complete the skill is not accepted (another start is tried)."""
    context = check_context(model)
    checkers = ordered_checks([*model.problem.families, *lazy_families()])

    def judge(theta: np.ndarray) -> Feasibility:
        records = run_checks(context, checkers, theta)
        return Feasibility(tuple(r.name for r in records if r.violated),
                           all(r.accepted for r in records), tuple(records),
                           min((r.clearance for r in records), default=math.inf))
    return judge


def solve(model: Model, warm_start: WarmStart | None = None,
          budget: Budget | None = None) -> Solution:
    """The :class:`Solution` of ``model``: optimised from ``model.problem.initial`` (the fast
    solver or the configured GTSAM optimizer; ``warm_start``: the fast solver's warm-start
    rule, for a start near the optimum) with every constraint inside one constrained solve
    (an augmented Lagrangian on the constraint families, :mod:`clamp.optim.constrained`),
    judged by their own checks (:func:`_judge`), its starts made by the declared search
    (:mod:`clamp.planning.search`) within ``budget`` (None: the config's ``budget`` and
    ``deadline``, counted from now)."""
    as_instance(model, "model", Model, "a clamp.planning.pipeline.Model (from clamp.planning.pipeline.model)",
                ClampTypeError)
    if warm_start is not None:
        as_instance(warm_start, "warm_start", WarmStart, "a clamp.optim.solver.WarmStart or None",
                    ClampTypeError)
    if budget is None:
        budget = Budget(model.config.optimizer.budget, model.config.optimizer.deadline)
    as_instance(budget, "budget", Budget, "a clamp.planning.search.Budget or None",
                ClampTypeError)
    context = check_context(model)
    lazy = {cls.name: (lambda cls=cls: cls.joining(context)) for cls in lazy_families()}
    solved = search(model, _judge(model), lazy, budget, warm_start)
    checks = solved.feasibility.checks
    own = next((c for c in checks if c.name == SelfCollisionFamily.name), None)
    if own is None:             # the chosen optimum collides with an obstacle: not yet checked
        own = SelfCollisionFamily.check(context, solved.out.theta)
        checks = (*checks, own)
    obstacle = next((c for c in checks if c.name == ObstacleFamily.name), None)
    attempts = tuple({"candidate": r.start, "round": r.index,
                      "min_distance": r.verdict.clearance, "feasible": r.verdict.ok,
                      "prior_cost": r.cost, "iterations": r.iterations,
                      "violated": r.verdict.violated} for r in solved.rounds)
    record = {"work": solved.work, "unit": solved.unit, "limit": solved.limit,
              "budget_ended": solved.budget_ended, "left": list(solved.left)}
    return Solution(solved.out, solved.problem, None if obstacle is None else obstacle.report,
                    own.report, attempts, checks, record)


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
