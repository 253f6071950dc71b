"""Constraints inside the solve: an augmented Lagrangian on the constraint families.

A plan must meet constraints, judged by the verdict's own checks (:class:`Feasibility`): no
collision with the obstacles on the robot's collision geometry, none with itself, joint
limits, constraint families such as orientation, and (with obstacles) the skill checks. The
families whose ``role`` is ``"constraint"`` (:mod:`clamp.factors.family`: hinges
e = max(0, g(theta) + s)) carry them into the least-squares problem. :func:`solve_constrained`
runs, per candidate start, the augmented-Lagrangian outer loop around the configured
optimizer (the fast Levenberg-Marquardt or GTSAM's):

1. solve the problem (each constraint family at its configured noise, shifts zero). A fresh
   start whose initial trajectory runs through an obstacle first takes one loose solve with the
   obstacle hinges ``soft_start`` times softer (stopping at ``soft_start_tolerance``): the first
   penalty of the schedule, letting the path slide around the obstacle before stiff hinges pin
   it (see docs/decisions.md#soft_start);
2. judge the optimum; stop when every check holds;
3. otherwise update every violated constraint family (its check fails): the multipliers,
   lambda <- max(0, lambda + mu g), i.e. the shift s = lambda / mu becomes the hinge's current
   residual max(0, g + s); and when the family's own violation (the largest max(0, g) over its
   residuals) did not fall below ``progress`` times the previous round's (always at its first
   update: a weight too weak to move the optimum leaves the multipliers too small to move it
   either), its penalty mu grows by ``stiffen`` ** 2 (noise / stiffen, shifts / stiffen ** 2).
   A constraint a check finds violated that the problem does not yet hold (``lazy``:
   self-collision, the skill's tube; see docs/decisions.md#lazy-constraints) joins here at its
   configured noise (stiffened at its next update) and holds from the start of every later
   candidate. A constraint family that holds while another fails gives way: its margin
   shrinks (:meth:`~clamp.factors.Family.relaxed`, down to ``margin_floor``) and, with
   ``update_active``, its active hinges' multipliers are updated too (see
   docs/decisions.md#relaxed-margins-and-active-multipliers);
4. re-solve from the optimum with the solver's warm-start rule; at most ``rounds`` updates per
   candidate (one more when a lazy constraint joins on the last), and up to ``polish_rounds``
   more while every failed check is within ``polish_reach`` times its family's ``near`` (a
   hair short; see docs/decisions.md#polish-rounds). A violated family whose hinges see less
   than half of what its check measures (the obstacle check measures the collision geometry
   between the support states too, the hinges only the spheres at them) is widened by the rest
   (:meth:`~clamp.factors.Family.widened`: the obstacle hinges' epsilon grows; see
   docs/decisions.md#widened-margins);
5. when no start passes after the search below, the ``resumed`` closest starts (their last
   optimum, the skill accepted), led by the problem as built when it had one solve only (the
   planner's tied problem), continue for ``resume_rounds`` more rounds each, outside the
   search budget, and while none passes, once more from there with the obstacles' safety
   distance ``wide_margin`` times the model's epsilon (see docs/decisions.md#resumed-starts).

Candidates: the problem as built, then the restarts the caller generates from what the loop
found so far (the untied problem, the skill's end as a goal, the detour search, a straight
line); past the first restart, none begins once the loop's work (solver trials and judged
optima, counted rather than timed: the same plan at any load) is ``search_budget`` times the
larger of its first candidate's and its first restart's first solve's (see
docs/decisions.md#detour-search). The
planner gives its tied problem (obstacles, tied to the free plan) one solve (``first_rounds``
0) and the restarts the rounds (see docs/decisions.md#the-tied-problems-one-solve). Once
``wanted`` candidates are feasible, or
one is and the next candidate would exceed the rounds it took, the loop stops and keeps the
feasible one of least prior cost (graph error of the cost families). The result's problem is
the one the chosen optimum solves, shifts and weights included: its GTSAM graph at the plan is
the one the solver finished on.

The schedule's constants (progress, stiffen, wanted, soft_start_tolerance, polish_rounds,
polish_reach, margin_floor, update_active, detours, ik_branches, search_budget, resumed,
resume_rounds, wide_margin) are the
``constraints`` group of the configuration (:class:`clamp.config.ConstraintConfig`).
"""
from __future__ import annotations

import logging
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, replace

import numpy as np

from clamp.config import ConstraintConfig, PlannerConfig
from clamp.factors import ConstraintCheck, Family, ObstacleFamily
from clamp.optim.optimizers import Optimized, optimize
from clamp.graph.problem import PlanningProblem
from clamp.optim.solver import WarmStart

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Feasibility:
    """What the verdict's checks say of one optimum: the constraint families found violated
    (by name, e.g. "obstacle", "joint_limits", "self_collision", "skill_tube"), whether the
    skill checks accept it (the skill completed), and every check's record to reuse
    (``checks``: :class:`clamp.factors.ConstraintCheck`, in the order they ran; ``reports``:
    name -> the check's report, e.g. "obstacle" -> the collision report)."""

    violated: tuple[str, ...]
    accepted: bool = True
    checks: tuple[ConstraintCheck, ...] = ()
    #: [m] the least real-geometry clearance to the obstacles (inf without)
    clearance: float = float("inf")

    @property
    def ok(self) -> bool:
        return not self.violated and self.accepted

    @property
    def reports(self) -> Mapping[str, object]:
        """The checks' reports by family name."""
        return {check.name: check.report for check in self.checks}


#: theta (T, 2n) -> what the checks say of it
Judge = Callable[[np.ndarray], Feasibility]
#: name -> maker of a constraint family the problem holds only once its check fails
Lazy = Mapping[str, Callable[[], Family]]


@dataclass(frozen=True)
class Candidate:
    """A start of the loop: its name and the problem (with its initial trajectory)."""

    name: str
    problem: PlanningProblem


@dataclass(frozen=True)
class Attempt:
    """One solve: the candidate, its round (0: as built), the obstacle hinge noise [m] (nan
    without), the least real-geometry clearance [m] of its optimum, whether every check holds,
    its prior cost [nats] (graph error of the cost families), accepted iterations and the
    constraint families the checks found violated."""

    candidate: str
    round: int
    sigma: float
    min_distance: float
    feasible: bool
    prior_cost: float
    iterations: int
    violated: tuple[str, ...]


@dataclass
class Progress:
    """What the loop has found so far (read by the restart generator)."""

    feasible: int = 0
    #: the judgement of the optimum that came closest (fewest violated checks, then clearance)
    closest: Feasibility | None = None


@dataclass(frozen=True)
class ConstrainedSolve:
    """The chosen optimum (iterations and trials summed over every attempt; initial error that
    of the first problem at its initial trajectory; final error that of ``problem`` at the
    plan), the problem it solves, its judgement and every attempt made."""

    out: Optimized
    problem: PlanningProblem
    feasibility: Feasibility
    attempts: list[Attempt]


def prior_cost(problem: PlanningProblem, theta: np.ndarray) -> float:
    """Graph error [nats] of the cost families (the posterior without constraint hinges)."""
    roles = {f.name: f.role for f in problem.families}
    return float(sum(v for name, v in problem.family_errors(theta).items()
                     if roles.get(name, "cost") == "cost"))


def _obstacle_sigma(problem: PlanningProblem) -> float:
    if not problem.has(ObstacleFamily.name):
        return float("nan")
    return 1.0 / float(problem.family(ObstacleFamily.name).whitening[0])


def _violation(family: Family, window) -> tuple[np.ndarray, float]:
    """The hinges' current residuals as the new shifts (F, m), and the family's violation:
    the largest max(0, g) [its units] over its residuals."""
    lin = family.residual(window, np.arange(len(family)), jacobians=False)
    shift = np.zeros((len(family), family.dim))
    shift[lin.rows] = lin.error
    before = np.broadcast_to(family.offset(lin.rows), lin.error.shape)
    violation = float(np.max(lin.error - before, initial=0.0))
    return shift, violation


def augmented(problem: PlanningProblem, theta: np.ndarray, violated: Iterable[str],
              previous: dict[str, float], lazy: Lazy,
              schedule: ConstraintConfig = ConstraintConfig(),
              amounts: Mapping[str, float] | None = None) -> PlanningProblem:
    """The next round's problem (see the module docstring, step 3), starting at theta (T, 2n);
    previous: each constraint family's violation of the round before (updated in place);
    schedule: ``progress`` and ``stiffen`` (the configuration's ``constraints`` group);
    amounts: the checks' violations by family name: a violated family whose hinges see less
    than half of its check's violation is widened by the rest
    (:meth:`~clamp.factors.Family.widened`)."""
    violated = set(violated)
    families = list(problem.families)
    present = {f.name for f in families}
    families += [lazy[name]() for name in sorted(violated - present) if name in lazy]
    window = problem.window(theta)
    out = []
    for family in families:
        if (family.role == "constraint" and family.name not in violated and violated
                and family.name in present):
            # holds while another fails: its margin gives way (down to the floor) and, where
            # its hinges are active, its multipliers are updated all the same
            family = family.relaxed(schedule.margin_floor) or family
            if schedule.update_active:
                shift, _ = _violation(family, window)
                if np.any(shift > 0.0):
                    family = family.with_shift(shift)
        if family.role != "constraint" or family.name not in violated:
            out.append(family)
            continue
        if family.name not in present:           # joins now, at its configured noise
            out.append(family)
            previous[family.name] = 0.0          # its first update stiffens it
            continue
        shift, violation = _violation(family, window)
        unseen = (amounts or {}).get(family.name, 0.0) - violation
        if unseen > violation:
            # the check sees what the hinges do not (e.g. between support states)
            family = family.widened(unseen) or family
        if violation > schedule.progress * previous.get(family.name, 0.0):
            family = family.reweighted(schedule.stiffen)
            shift /= schedule.stiffen ** 2
        previous[family.name] = violation
        out.append(family.with_shift(shift))
    return problem.with_families(out, theta)


def _scaled(families: list[Family], name: str, factor: float) -> list[Family]:
    """``families`` with the one called ``name`` reweighted by ``factor`` (noise / factor)."""
    return [f.reweighted(factor) if f.name == name else f for f in families]


def _closeness(verdict: Feasibility) -> tuple[int, float]:
    """Order of how close an infeasible optimum came: fewer violated checks, then more
    clearance (smaller is closer)."""
    return len(verdict.violated), -verdict.clearance


def solve_constrained(problem: PlanningProblem, config: PlannerConfig, judge: Judge,
                      restarts: Callable[[Progress], Iterable[Candidate]] = lambda _: (),
                      lazy: Lazy | None = None, warm_start: WarmStart | None = None,
                      first_rounds: int | None = None) -> ConstrainedSolve:
    """Optimise ``problem`` until ``judge`` finds every constraint met (see the module
    docstring); restarts(progress): further candidates, generated lazily once the problem as
    built fails; lazy: constraint families joining when their check fails; warm_start: the
    solver's warm-start rule for the first solve (its initial trajectory is a previous plan,
    :func:`clamp.replan`), never for the restarts. ``config.optimizer.constraint_rounds``:
    updates per candidate (0: the first solve only); first_rounds: the problem as built's
    instead (0: one solve, the restarts get the rounds: the planner's tied problem)."""
    started = time.perf_counter()
    rounds = int(config.optimizer.constraint_rounds)
    lazy = lazy or {}
    attempts: list[Attempt] = []
    found: list[tuple[Optimized, PlanningProblem, Feasibility, float]] = []
    totals = {"iterations": 0, "trials": 0}
    progress = Progress()
    timings: dict[str, float] = {}
    initial_error = None        # set by the first solve's soft stage; else that solve's own
    joined: set[str] = set()    # lazy constraints that joined on some start

    def solve(name: str, r: int, current: PlanningProblem, warm: WarmStart | None,
              before: Optimized | None = None) -> tuple[Optimized, Feasibility]:
        """Solve ``current`` (after the soft stage ``before``, whose work it counts) and judge."""
        out = optimize(current, config, warm)
        for k, v in out.timings.items():
            timings[k] = timings.get(k, 0.0) + v
        iterations = out.iterations + (before.iterations if before else 0)
        totals["iterations"] += iterations
        totals["trials"] += out.trials + (before.trials if before else 0)
        clock = time.perf_counter()
        verdict = judge(out.theta)
        timings["checks"] = timings.get("checks", 0.0) + time.perf_counter() - clock
        cost = prior_cost(current, out.theta)
        attempts.append(Attempt(name, r, _obstacle_sigma(current), verdict.clearance,
                                verdict.ok, cost, iterations, verdict.violated))
        found.append((out, current, verdict, cost))
        if verdict.ok:
            progress.feasible += 1
        if progress.closest is None or _closeness(verdict) < _closeness(progress.closest):
            progress.closest = verdict
        return out, verdict

    def run(candidate: Candidate, warm: WarmStart | None, budget: int) -> int | None:
        """The outer loop on one candidate; the round it became feasible, or None."""
        nonlocal initial_error
        begun = work()
        roots.setdefault(candidate.name, candidate.problem)
        current = candidate.problem
        carried = [lazy[name]() for name in sorted(joined) if not current.has(name)]
        if carried:        # a constraint that joined on an earlier start holds from the start
            current = current.with_families([*current.families, *carried], current.initial)
        soft = None
        factor = float(config.optimizer.soft_start)
        if warm is None and factor > 1.0 and current.has(ObstacleFamily.name):
            obstacles = current.family(ObstacleFamily.name)
            if obstacles.penetration(current.window(current.initial)) > 0.0:
                soft = optimize(current.with_families(
                    _scaled(current.families, ObstacleFamily.name, 1.0 / factor),
                    current.initial),
                    config.with_(relative_error_tol=config.constraints.soft_start_tolerance,
                                 convergence_patience=1))
                if not found:    # the first solve: the problem as asked, at its initial
                    initial_error = current.error(current.initial)
                current = current.with_families(current.families, soft.theta)
                warm = WarmStart()
        previous: dict[str, float] = {}
        r = polished = 0
        while True:
            out, verdict = solve(candidate.name, r, current, warm, soft)
            soft = None
            if r == 0 and len(unit) == 1:        # the first restart's first solve (from scratch)
                unit.append(work() - begun)
            if verdict.ok:
                return r
            joins = budget > 0 and any(name in lazy and not current.has(name)
                                       for name in verdict.violated)
            if _faulted(verdict) or not verdict.violated:
                return None       # a refused skill needs another start, not stiffer hinges
            if r >= budget and not (joins and r == budget):
                # a hair short: keep updating the active constraints (polish rounds)
                # (not bounded by the search budget: a hair short is finished, not searched);
                # a lazy constraint the polishing pushed the plan across joins as a polish
                # round (fixing a velocity, then a contact, the path left the skill's tube)
                if not (budget > 0 and polished < config.constraints.polish_rounds
                        and verdict.accepted
                        and ((joins and polished > 0)
                             or _near(verdict, current, config.constraints.polish_reach))):
                    return None
                polished += 1
            joined.update(name for name in verdict.violated
                          if name in lazy and not current.has(name))
            current = augmented(current, out.theta, verdict.violated, previous, lazy,
                                config.constraints, _amounts(verdict))
            warm, r = WarmStart(), r + 1

    def work() -> int:
        """The loop's work so far: solver trials (linearisations) and judged optima; counted,
        not timed, so that the budget gives the same plan on any machine at any load."""
        return totals["trials"] + len(attempts)

    schedule = config.constraints
    #: the problem each start began with (its configured weights, no shifts), by name
    roots: dict[str, PlanningProblem] = {}
    #: the work of the problem as built's solve (judged) and of the first restart's first solve
    #: (from scratch): the budget's unit is the larger
    unit: list[int] = []

    def within_budget() -> bool:
        limit = config.constraints.search_budget
        return limit is None or not unit or work() <= limit * max(unit)

    first_ok = run(Candidate("configured", problem), warm_start,
                   rounds if first_rounds is None else min(int(first_rounds), rounds))
    unit.append(work())
    if first_ok is None and rounds > 0 and not _faulted(found[-1][2]):
        for k, candidate in enumerate(restarts(progress)):
            if progress.feasible >= config.constraints.wanted:
                break
            if k > 0 and not within_budget():      # the first restart always runs
                log.info("search budget of %.3g first solves spent: no start past %s",
                         config.constraints.search_budget, candidate.name)
                break
            ok = run(candidate, None, rounds if first_ok is None else first_ok)
            first_ok = ok if first_ok is None else first_ok

    # the problem as built continues first when it had one solve only (the planner's tied
    # problem: its rounds went to the restarts)
    tied = "configured" if first_rounds is not None and int(first_rounds) == 0 else None

    def resume(suffix: str, make: Callable[[PlanningProblem, PlanningProblem, np.ndarray,
                                            Feasibility], PlanningProblem | None],
               warm: WarmStart | None, budget: int) -> None:
        """The closest starts continued (module docstring, step 5) from their last optimum
        as ``make(the start as it began, its last problem, theta, verdict)`` sets them up,
        until one passes."""
        for root, name, (out, current, verdict, _) in _resumable(found, attempts,
                                                                 schedule.resumed, tied):
            continued = make(roots[root], current, out.theta, verdict)
            if continued is not None and run(Candidate(f"{name}+{suffix}", continued),
                                             warm, budget) is not None:
                return

    if not progress.feasible and rounds > 0 and not _faulted(found[-1][2]):
        # the rounds go on: the multipliers and penalties as they were
        resume("resumed", lambda _, current, theta, verdict: augmented(
            current, theta, verdict.violated, {}, lazy, schedule, _amounts(verdict)),
            WarmStart(), schedule.resume_rounds - 1)
        if not progress.feasible and schedule.wide_margin > 1.0:
            # a new problem from there: the start's own weights, a wider safety distance
            resume("wide", lambda began, _, theta, __: _wide(
                began, theta, schedule.wide_margin * config.model.epsilon),
                None, schedule.resume_rounds)
    out, solved, verdict = _choose(found)
    timings["constraint_loop"] = time.perf_counter() - started
    chosen = replace(out, iterations=totals["iterations"], trials=totals["trials"],
                     stop_reason=out.stop_reason if verdict.ok else "infeasible",
                     timings=timings,
                     initial_error=found[0][0].initial_error if initial_error is None
                     else initial_error)
    if not verdict.ok and len(found) > 1:
        log.info("no plan meets every constraint after %d attempts; kept the closest (%s)",
                 len(found), ", ".join(verdict.violated) or "refused by the skill checks")
    return ConstrainedSolve(chosen, solved, verdict, attempts)


def _wide(problem: PlanningProblem, theta: np.ndarray, epsilon: float
          ) -> PlanningProblem | None:
    """``problem`` (a start as it began) at theta with its obstacle family's safety distance
    widened to ``epsilon`` [m] (kept where it is wider already); None without obstacles."""
    if not problem.has(ObstacleFamily.name):
        return None
    obstacles = problem.family(ObstacleFamily.name)
    wider = obstacles.widened(epsilon - obstacles.epsilon) if epsilon > obstacles.epsilon \
        else obstacles
    return problem.with_families([wider if f.name == ObstacleFamily.name else f
                                  for f in problem.families], theta)


def _amounts(verdict: Feasibility) -> dict[str, float]:
    """The violated checks' amounts by family name."""
    return {check.name: check.amount for check in verdict.checks if check.violated}


def _resumable(found: list, attempts: list[Attempt], count: int, first: str | None = None
               ) -> list[tuple[str, str, tuple]]:
    """The last optimum of each start (a continued start counts as its own: "untied" and
    "untied+resumed" are one) when the constraints alone refuse it (the skill accepted, a
    constraint violated), closest first (:func:`_closeness`), at most ``count``: (the start's
    own name, the name of the attempt it continues, what ``found`` holds of it). With
    ``count`` > 0 the start called ``first`` leads when it is resumable, added to the
    ``count`` closest when it is not among them."""
    last: dict[str, int] = {}
    for k, attempt in enumerate(attempts):
        last[attempt.candidate.split("+")[0]] = k
    ends = [(root, attempts[k].candidate, found[k]) for root, k in last.items()
            if found[k][2].violated and found[k][2].accepted]
    ends.sort(key=lambda item: _closeness(item[2][2]))
    chosen = ends[:count]
    lead = [item for item in ends if item[0] == first] if count > 0 else []
    return lead + [item for item in chosen if item[0] != first]


def _near(verdict: Feasibility, problem: PlanningProblem, reach: float = 1.0) -> bool:
    """Whether every check ``verdict`` fails is a constraint family of ``problem`` violated by
    at most ``reach`` times its ``near`` (a hair short of passing: worth more updates of the
    same start)."""
    near = {f.name: reach * float(getattr(f, "near", 0.0)) for f in problem.families}
    return all(check.name in near and check.amount <= near[check.name]
               for check in verdict.checks if check.violated)


def _faulted(verdict: Feasibility) -> bool:
    return any(getattr(rep, "fault", None) for rep in verdict.reports.values())


def _choose(found: list) -> tuple[Optimized, PlanningProblem, Feasibility]:
    """The feasible optimum of least prior cost; else one that only the skill checks refuse
    (least prior cost); else the closest: fewest violated checks, then largest clearance, then
    the latest (the most updated multipliers)."""
    feasible = [f for f in found if f[2].ok]
    if feasible:
        return min(feasible, key=lambda f: f[3])[:3]
    refused = [f for f in found if not f[2].violated]
    if refused:
        return min(refused, key=lambda f: f[3])[:3]
    k = min(range(len(found)), key=lambda k: (*_closeness(found[k][2]), -k))
    return found[k][:3]
