"""The search for a plan that passes its checks: a declared, ordered list of start strategies
and one driver, under a budget.

Each :class:`Strategy` has a name, how it makes its starts (problem and initial trajectory)
and what each start may spend (its augmented-Lagrangian updates and polish rounds,
:func:`clamp.optim.constrained.solve_start`). :data:`STRATEGIES`, in order:

1. ``tied``: the problem as built, tied to the free plan's posture: one solve (its updates
   come later); ``configured`` instead when the problem has no tie (its updates at once);
2. ``untied``: the same without the tie (the free plan's posture led into the obstacles);
3. ``tied_resumed``: the tied problem continued from its optimum, its own updates
   (docs/decisions.md#the-declared-search-and-its-budget-issue-36);
4. ``to_end``: untied with the demonstrations' mean end as a goal, when the closest optimum so
   far did not complete the skill and no goal was asked;
5. ``detours``: the skill's path taken over, left, right and under every obstacle blocking it,
   ranked in the workspace before any solve (:func:`clamp.planning.detours.detour_search`),
   the best :data:`DETOURS`;
6. ``ik_branches``: other inverse-kinematics solutions of an end-effector start;
7. ``straight_line``: a straight line in joint space;
8. ``resumed``: the :data:`RESUMED` closest starts continue their updates from their last
   optimum;
9. ``wide``: the same starts from their last optimum as new problems whose obstacle safety
   distance is :data:`WIDE_MARGIN` times the model's.

The fresh restarts 5-7 of a pose prior begin along trajectories turned towards its mean
rotations (:func:`joint_path`; docs/decisions.md#restarts-keep-the-penalty).

Strategies 2-7 run only with obstacles; every strategy after the first only while no start
passed, no check reported a fault and the config allows updates (``constraint_rounds`` > 0).
The driver stops at the first start that passes.

The budget (:class:`Budget`) bounds every request, failures included. By default it is
counted work (solver trials and judged optima, :class:`clamp.optim.constrained.Ledger`), in
units of the first solves (the larger of the first start's whole work and the second start's
first solve), so the same request gives the same plan at any load; ``seconds`` adds a
wall-clock deadline. The first two starts always run under the counted budget (its unit is
their work), the first alone under a deadline; no later one begins once the budget is spent,
and a deadline also stops a start between its updates and its solver between iterations
(a solve it stops is not judged, unless nothing was judged yet: the call returns within an
iteration of the deadline, not a judgement after it). A search the budget ended says
so (:class:`Searched`: ``budget_ended`` and the strategies ``left``), and its plan is the
closest attempt with its honest verdict.
"""
from __future__ import annotations

import logging
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from clamp.factors import EEPositionFamily, JointTargetFamily, ObstacleFamily, PostureFamily
from clamp.graph.problem import PlanningProblem
from clamp.optim.constrained import (ALConfig, Feasibility, Judge, Lazy, Ledger, Round, Start,
                                     chosen, resumed, solve_start)
from clamp.optim.optimizers import Optimized
from clamp.optim.solver import WarmStart
from clamp.planning.assembly import configured_initialisation, without_family
from clamp.planning.clearance import check_clearance
from clamp.planning.detours import detour_search, detour_trajectory
from clamp.planning.initialisation import Initialisation, pose_refined
from clamp.planning.progress import SearchProgress, report
from clamp.planning.reach import reach_radius
from clamp.planning.request import IK_TOLERANCE
from clamp.prior.skill import TUBE_RATIO, SkillRegion
from clamp.validation import as_scalar
from robots.self_collision import self_collision_report

log = logging.getLogger(__name__)

#: updates more while every failed check is within POLISH_REACH times its family's ``near``
#: (docs/decisions.md#polish-rounds)
POLISH_ROUNDS = 3
POLISH_REACH = 2.0
#: a fresh start whose initial trajectory runs through an obstacle first solves with the
#: obstacle noise this many times larger, loosely (docs/decisions.md#soft_start)
SOFT_START = 4.0
#: detours solved at most (docs/decisions.md#detour-search)
DETOURS = 3
#: other IK branches of an end-effector start tried at most
IK_BRANCHES = 2
#: [rad] another IK branch differs from the start configuration (and the other branches) by
#: at least this in some joint
BRANCH_APART = 0.5
#: the closest starts resumed, and the updates each gets (docs/decisions.md#resumed-starts)
RESUMED = 2
RESUME_ROUNDS = 4
#: the wide starts' obstacle safety distance, in units of the model's epsilon
WIDE_MARGIN = 4.0
#: the schedule of the augmented Lagrangian
AL = ALConfig()


@dataclass(frozen=True)
class Budget:
    """What one request may spend on its search: ``work`` in units of its first solves
    (counted: the same plan at any load; None: unbounded) and ``seconds`` of wall clock from
    ``started`` (``time.perf_counter()``; None: no deadline)."""

    work: float | None
    seconds: float | None = None
    started: float = field(default_factory=time.perf_counter)

    def __post_init__(self) -> None:
        if self.work is not None:
            as_scalar(self.work, "budget", minimum=0.0)
        if self.seconds is not None:
            as_scalar(self.seconds, "deadline", minimum=0.0)

    def late(self, reserve: float = 0.0) -> bool:
        """Whether the deadline has passed, or comes within ``reserve`` [s] (the time the
        judgement of what is solved now will take)."""
        return (self.seconds is not None
                and time.perf_counter() - self.started + reserve > self.seconds)


@dataclass
class Context:
    """What the strategies read: the model (:class:`clamp.planning.pipeline.Model`), the ledger
    of every judged optimum so far, the problem without the posture tie and the start problem
    of every lineage."""

    model: Any
    ledger: Ledger
    lazy: Lazy
    untied: PlanningProblem
    roots: dict[str, PlanningProblem] = field(default_factory=dict)


#: a strategy's starts: (name, problem, lineage or "", continued: warm-started from an optimum)
Made = tuple[str, PlanningProblem, str, bool]


@dataclass(frozen=True)
class Strategy:
    """A way to start the constrained solve: ``name``, ``make(context)`` -> its starts
    (:data:`Made`, generated when its turn comes), the updates and polish rounds each start may
    spend (``rounds`` None: the config's ``constraint_rounds``), and whether it belongs to the
    restarts among obstacles (``obstacles``)."""

    name: str
    make: Callable[[Context], Iterable[Made]]
    rounds: int | None = None
    polish: int = POLISH_ROUNDS
    obstacles: bool = False


def _tied(context: Context) -> Iterator[Made]:
    if context.model.problem.has(PostureFamily.name):
        yield "tied", context.model.problem, "", False


def _configured(context: Context) -> Iterator[Made]:
    if not context.model.problem.has(PostureFamily.name):
        yield "configured", context.model.problem, "", False


def _untied(context: Context) -> Iterator[Made]:
    if context.model.problem.has(PostureFamily.name):
        yield "untied", context.untied, "", False


def _to_end(context: Context) -> Iterator[Made]:
    closest, model = context.ledger.closest, context.model
    if (closest is not None and not closest.violated and not closest.accepted
            and model.request.goal is None):
        end = SkillRegion.of(model.prior).end_mean
        goal = EEPositionFamily([model.problem.num_states - 1], end[None],
                                [model.config.model.goal_sigma])
        untied = context.untied
        yield "to_end", untied.with_families([*untied.families, goal], untied.initial), "", False


def _detours(context: Context) -> Iterator[Made]:
    model = context.model
    if model.scene is None:
        return
    prior, robot, config = model.prior, model.robot, model.config
    reference = np.asarray(model.reference.mean)[:, :3]
    tube = TUBE_RATIO * SkillRegion.of(prior).tube
    ranked = detour_search(model.initialisation.path, model.scene.obstacles, reference, tube,
                           2.0 * config.model.epsilon, np.zeros(3), reach_radius(robot),
                           focus(context.ledger.closest))
    for name, path, _ in ranked[:DETOURS]:
        theta = joint_path(model, path, model.request.q_start)
        yield f"detour_{name}", context.untied.with_families(context.untied.families, theta), \
            "", False


def _ik_branches(context: Context) -> Iterator[Made]:
    model, untied = context.model, context.untied
    for k, q0 in enumerate(other_branches(model, IK_BRANCHES)):
        theta = joint_path(model, model.initialisation.path, q0)
        yield f"ik_branch_{k}", untied.with_families([started_at(f, q0) for f in untied.families],
                                                     theta), "", False


def _straight_line(context: Context) -> Iterator[Made]:
    model = context.model
    if model.config.optimizer.initialisation != "straight_line":
        line = configured_initialisation(model.prior, model.robot, model.request,
                                         model.config.with_(initialisation="straight_line"))
        yield "straight_line", context.untied.with_families(context.untied.families,
                                                            line.theta), "", False


def _tied_resumed(context: Context) -> Iterator[Made]:
    for judged in resumable(context.ledger):
        if judged.root == "tied":
            yield "tied+resumed", resumed(judged, context.lazy, AL), judged.root, True


def _resumed(context: Context) -> Iterator[Made]:
    for judged in resumable(context.ledger):
        if judged.root != "tied" or judged.start == "tied":
            yield f"{judged.start}+resumed", resumed(judged, context.lazy, AL), judged.root, \
                True


def _wide(context: Context) -> Iterator[Made]:
    epsilon = WIDE_MARGIN * context.model.config.model.epsilon
    for judged in resumable(context.ledger):
        began = context.roots[judged.root]
        if began.has(ObstacleFamily.name):
            yield f"{judged.start}+wide", widened(began, judged.out.theta, epsilon), \
                judged.root, False


def joint_path(model: Any, path: np.ndarray, q0: np.ndarray) -> np.ndarray:
    """The joint states (T, 2n) of a restart along the hand's ``path`` (T, 3) [m] from q0 (n,):
    inverse kinematics (:func:`clamp.planning.detours.detour_trajectory`), for a pose prior
    then turned towards its conditioned mean rotations as the initial guess is
    (:func:`clamp.planning.initialisation.pose_refined`): a restart that turns the hand away
    from the skill starts against its orientation chain."""
    dt = float(model.prior.dt)
    theta = detour_trajectory(model.robot, path, q0, dt, IK_TOLERANCE)
    orientation = getattr(model.model_prior, "orientation", None)
    if orientation is None:
        return theta
    n = model.robot.n
    guess = Initialisation(theta[:, :n], theta[:, n:], path, np.zeros(len(path)))
    return pose_refined(model.robot, guess, orientation.mean_rotations, dt).theta


#: the search, in order (module docstring)
STRATEGIES = (
    Strategy("tied", _tied, rounds=0),
    Strategy("configured", _configured),
    Strategy("untied", _untied, obstacles=True),
    Strategy("tied_resumed", _tied_resumed, rounds=RESUME_ROUNDS - 1, obstacles=True),
    Strategy("to_end", _to_end, obstacles=True),
    Strategy("detours", _detours, obstacles=True),
    Strategy("ik_branches", _ik_branches, obstacles=True),
    Strategy("straight_line", _straight_line, obstacles=True),
    Strategy("resumed", _resumed, rounds=RESUME_ROUNDS - 1),
    Strategy("wide", _wide, rounds=RESUME_ROUNDS),
)


@dataclass(frozen=True)
class Searched:
    """The search's plan: ``out`` (the chosen optimum, iterations and trials summed over every
    solve, the initial error of the first problem), the ``problem`` it solves (shifts and
    weights as the solver finished), its judgement, every judged optimum (``rounds``), the
    work spent, the budget's unit (the first solves' work) and its limit in the same units
    (None: unbounded), whether the budget ended the search and the strategies it left."""

    out: Optimized
    problem: PlanningProblem
    feasibility: Feasibility
    rounds: tuple[Round, ...]
    work: int
    unit: int
    limit: float | None
    budget_ended: bool = False
    left: tuple[str, ...] = ()


def search(model: Any, judge: Judge, lazy: Lazy, budget: Budget,
           warm_start: WarmStart | None = None) -> Searched:
    """Run :data:`STRATEGIES` on ``model`` (module docstring) under ``budget``; ``judge``: the
    verdict's checks of an optimum; ``lazy``: the constraint families that join when their
    check fails; ``warm_start``: the solver's rule for the first start (its initial trajectory
    is a previous plan)."""
    problem = model.problem
    ledger = Ledger()
    context = Context(model, ledger, lazy, without_family(problem, PostureFamily.name,
                                                          model.initialisation.theta))
    spend = _Spending(budget)
    ended: tuple[str, ...] = ()
    for k, strategy in enumerate(STRATEGIES):
        if not _applies(strategy, model, ledger):
            continue
        starts = iter(strategy.make(context))
        # the budget is checked before a strategy makes a start (a detour's IK costs too)
        while not spend.exhausted(ledger):
            name, start_problem, lineage, warm = next(starts, (None,) * 4)
            if name is None:
                break
            start = _start(strategy, name, start_problem, lineage, warm, model,
                           warm_start if not ledger.rounds else None)
            context.roots.setdefault(start.root, start.problem)
            begun = ledger.work
            solve_start(start, model.config, judge, ledger, lazy, AL, budget.late)
            spend.measured(ledger, begun)
            report(SearchProgress(spend.starts, len(ledger.rounds), ledger.work, spend.limit,
                                  ledger.feasible is not None))
            if _finished(ledger):
                break
        else:
            ended = tuple(s.name for s in STRATEGIES[k:] if _applies(s, model, ledger))
        if ended or _finished(ledger):
            break
    return _searched(ledger, spend, ended)


def _applies(strategy: Strategy, model: Any, ledger: Ledger) -> bool:
    """Whether ``strategy`` runs now: the first always; the others while no start passed and
    no check faulted, and the config allows updates (``constraint_rounds`` > 0); the obstacle
    restarts only with obstacles."""
    if not ledger.rounds:
        return True
    if _finished(ledger) or model.config.optimizer.constraint_rounds == 0:
        return False
    return not strategy.obstacles or model.problem.has(ObstacleFamily.name)


def _judging(ledger: Ledger) -> float:
    """[s] what judging an optimum has taken on average so far (0 before the first)."""
    return ledger.timings.get("checks", 0.0) / max(1, len(ledger.rounds))


def _finished(ledger: Ledger) -> bool:
    """Whether the search is over: a start passed, or the last optimum's check faulted."""
    return bool(ledger.rounds) and (ledger.feasible is not None
                                    or ledger.rounds[-1].verdict.faulted)


def _start(strategy: Strategy, name: str, problem: PlanningProblem, lineage: str,
           continued: bool, model: Any, warm: WarmStart | None) -> Start:
    """The :class:`Start` of one made start: the strategy's rounds; a continued one
    warm-started, a fresh one whose initial trajectory runs through an obstacle first solved
    loosely (:data:`SOFT_START`; not in the weighted solve alone, ``constraint_rounds`` 0)."""
    warm = WarmStart() if continued else warm
    rounds = model.config.optimizer.constraint_rounds
    soften = {}
    if warm is None and rounds > 0 and SOFT_START > 1.0 and problem.has(ObstacleFamily.name):
        obstacles = problem.family(ObstacleFamily.name)
        if obstacles.penetration(problem.window(problem.initial)) > 0.0:
            soften = {ObstacleFamily.name: SOFT_START}
    rounds = rounds if strategy.rounds is None else strategy.rounds
    return Start(name, problem, rounds, strategy.polish, POLISH_REACH, soften, warm, lineage)


class _Spending:
    """The budget's account: its unit (the first start's work and the second start's first
    solve, the larger), and whether a further start may begin."""

    def __init__(self, budget: Budget):
        self.budget, self.units, self.starts = budget, [], 0

    def measured(self, ledger: Ledger, begun: int) -> None:
        self.starts += 1
        if self.starts == 1:
            self.units.append(ledger.work)
        elif self.starts == 2:
            first = next((r.work for r in ledger.rounds if r.work > begun), ledger.work)
            self.units.append(first - begun)    # (the whole start's, had a deadline halted it)

    @property
    def limit(self) -> float | None:
        work = self.budget.work
        return None if work is None or not self.units else work * max(self.units)

    def exhausted(self, ledger: Ledger) -> bool:
        """Whether no further start may begin: past the deadline (the first start always
        runs), or past the counted limit (the first two always run: the limit's unit)."""
        if self.starts >= 1 and self.budget.late(_judging(ledger)):
            return True
        limit = self.limit
        return self.starts >= 2 and limit is not None and ledger.work > limit


def _searched(ledger: Ledger, spend: _Spending, ended: tuple[str, ...]) -> Searched:
    plan = chosen(ledger)
    out = replace(plan.out, iterations=ledger.iterations, trials=ledger.trials,
                  stop_reason=plan.out.stop_reason if plan.verdict.ok else "infeasible",
                  timings=dict(ledger.timings), initial_error=ledger.initial_error)
    if ended:
        log.info("the search's budget ended it after %d units of work; left: %s",
                 ledger.work, ", ".join(ended))
    return Searched(out, plan.problem, plan.verdict, tuple(ledger.rounds), ledger.work,
                    max(spend.units), spend.limit, bool(ended), ended)


def resumable(ledger: Ledger) -> list[Round]:
    """The last optimum of each lineage that the constraints alone refuse (the skill
    accepted, a constraint violated), the tied problem's first, then the :data:`RESUMED`
    closest of the others."""
    last: dict[str, Round] = {}
    for judged in ledger.rounds:
        last[judged.root] = judged
    ends = sorted((r for r in last.values() if r.verdict.violated and r.verdict.accepted),
                  key=lambda r: r.verdict.closeness())
    lead = [r for r in ends if r.root == "tied"]
    return lead + [r for r in ends[:RESUMED] if r.root != "tied"]


def widened(problem: PlanningProblem, theta: np.ndarray, epsilon: float) -> PlanningProblem:
    """``problem`` (a start as it began) at theta with its obstacle safety distance widened to
    ``epsilon`` [m] (kept where it is wider already)."""
    obstacles = problem.family(ObstacleFamily.name)
    wider = (obstacles.widened(epsilon - obstacles.epsilon) if epsilon > obstacles.epsilon
             else obstacles)
    return problem.with_families([wider if f.name == ObstacleFamily.name else f
                                  for f in problem.families], theta)


def other_branches(model: Any, count: int) -> list[np.ndarray]:
    """Up to ``count`` other inverse-kinematics solutions (n,) of an end-effector start (the
    user gave a position; the planner chose ``request.q_start``): from seeded random
    configurations, each at least :data:`BRANCH_APART` from the start configuration and from
    each other in some joint, within the limits, clear of the arm itself and of the scene;
    none for a joint start."""
    request, robot, config = model.request, model.robot, model.config
    if count <= 0 or request.start.kind != "position":
        return []
    out: list[np.ndarray] = []
    rng = np.random.default_rng(0)
    for attempt in range(4 * count):
        if len(out) >= count:
            break
        ik = robot.ik(request.start.value, seed=robot.random_configuration(rng),
                      tol=IK_TOLERANCE, rng=attempt)
        q0 = np.asarray(ik.q, dtype=float)
        if (ik.error > IK_TOLERANCE
                or not bool(np.all(robot.within_limits(q0[None], tolerance=0.0)))
                or any(float(np.max(np.abs(q0 - q))) < BRANCH_APART
                       for q in (request.q_start, *out))):
            continue
        if self_collision_report(robot, q0[None]).collision:
            continue
        report = check_clearance(robot, model.scene, q0[None])
        if report is not None and report.collision:
            continue
        out.append(q0)
    return out


def started_at(family: Any, q0: np.ndarray) -> Any:
    """``family`` with its joint target at state 0 moved to q0 (n,) (others as they are)."""
    if family.name != JointTargetFamily.name or 0 not in family.first:
        return family
    targets = np.array(family.targets, dtype=float)
    targets[family.first == 0] = q0
    return JointTargetFamily(family.first, targets, 1.0 / np.asarray(family.whitening))


def focus(closest: Feasibility | None) -> int | None:
    """The state where the closest optimum failed: the skill's worst state when it left the
    tube, else the obstacle contact's (None: neither)."""
    if closest is None:
        return None
    skill = closest.reports.get("skill_tube")
    if skill is not None and not getattr(skill, "within_tube", True):
        return int(skill.worst)
    contact = closest.reports.get(ObstacleFamily.name)
    if contact is not None and getattr(contact, "nearest", None) is not None:
        return int(round(float(contact.nearest.index)))
    return None
