"""Constrained least squares: an augmented Lagrangian on the families that declare themselves
constraints.

A problem's families each declare their kind (:attr:`clamp.factors.Family.role`): a ``"cost"``
is a least-squares term; a ``"constraint"`` g(theta) <= 0 is a hinge e = max(0, g + s)
(:mod:`clamp.factors.family`). The augmented Lagrangian's state is the problem itself: per
constraint family its shifts s = lambda / mu (the multipliers over the penalty) and its
whitening (sqrt of the penalty mu). :func:`update` is the one update of that state (jaxls'
``update_al_state`` is the model):

- the multipliers of a violated family, lambda <- max(0, lambda + mu g): the shift becomes the
  hinge's current residual max(0, g + s);
- its penalty grows by ``stiffen`` ** 2 (noise / stiffen) when its violation (the largest
  max(0, g) over its residuals) did not fall below ``progress`` times the previous update's;
- a family that holds while another fails gives way (:meth:`~clamp.factors.Family.relaxed`,
  down to ``margin_floor``) and, with ``update_active``, its active hinges' multipliers are
  updated too;
- a violated family whose check measures more than twice what its hinges see is widened by the
  rest (:meth:`~clamp.factors.Family.widened`: the check sees between the support states);
- a lazy constraint (a family the problem holds only once its check fails) joins at its
  configured noise.

:func:`solve_start` runs the outer loop for one :class:`Start`: solve (the configured
optimizer), judge (a :data:`Judge` of the caller's: what the checks say of an optimum), update,
until the judge accepts the optimum or the start's rounds are spent. Every judged optimum is
written in a :class:`Ledger`, whose work (solver trials and judged optima: counted, not timed)
a caller may budget. Which starts to try, in which order and under which budget is the
caller's (:mod:`clamp.planning.search`).
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np

from clamp.config import PlannerConfig
from clamp.factors.family import ConstraintCheck, Family
from clamp.graph.problem import PlanningProblem
from clamp.optim.optimizers import Optimized, optimize
from clamp.optim.solver import HALTED, WarmStart


@dataclass(frozen=True)
class ALConfig:
    """The augmented Lagrangian's schedule (see the module docstring)."""

    #: a constraint family's violation must fall below this fraction of the previous
    #: update's, or its penalty grows (docs/decisions.md#progress-and-stiffen)
    progress: float = 0.25
    #: noise divisor of a family whose violation did not fall enough (penalty x stiffen ** 2)
    stiffen: float = 4.0
    #: [the family's units] the least margin a family that gives way keeps
    #: (docs/decisions.md#relaxed-margins-and-active-multipliers)
    margin_floor: float = 0.005
    #: also update the multipliers of families that hold but whose hinges are active
    update_active: bool = True
    #: relative error decrease below which a start's loose first solve stops
    #: (docs/decisions.md#soft_start_tolerance)
    soft_tolerance: float = 3e-2


@dataclass(frozen=True)
class Feasibility:
    """What the judge's checks say of one optimum: the constraint families found violated (by
    name), whether the checks accept it without a constraint to tighten (``accepted`` False:
    another start is needed), every check's record (:class:`clamp.factors.ConstraintCheck`, in
    the order they ran) and the least clearance [m] a check measured (inf: none)."""

    violated: tuple[str, ...]
    accepted: bool = True
    checks: tuple[ConstraintCheck, ...] = ()
    clearance: float = math.inf

    @property
    def ok(self) -> bool:
        return not self.violated and self.accepted

    @property
    def reports(self) -> Mapping[str, object]:
        """The checks' reports by family name."""
        return {check.name: check.report for check in self.checks}

    @property
    def faulted(self) -> bool:
        """Whether a check's report records a fault (no start or update helps)."""
        return any(getattr(rep, "fault", None) for rep in self.reports.values())

    def closeness(self) -> tuple[int, float]:
        """How close an infeasible optimum came, smaller closer: fewer violated checks, then
        more clearance."""
        return len(self.violated), -self.clearance


#: theta (T, 2n) -> what the checks say of it
Judge = Callable[[np.ndarray], Feasibility]
#: name -> maker of a constraint family the problem holds only once its check fails
Lazy = Mapping[str, Callable[[], Family]]


@dataclass(frozen=True)
class Start:
    """One start of the outer loop: ``name``; ``problem`` with its initial trajectory;
    ``rounds``: updates at most; ``polish``: updates more while every failed check is within
    ``reach`` times its family's ``near`` (a hair short); ``soften``: family name -> factor (> 1)
    by which its noise is multiplied in one loose first solve (none with ``warm``);
    ``warm``: the solver's warm-start rule for the first solve; ``lineage``: the start it
    continues (its own name by default)."""

    name: str
    problem: PlanningProblem
    rounds: int
    polish: int = 0
    reach: float = 1.0
    soften: Mapping[str, float] = field(default_factory=dict)
    warm: WarmStart | None = None
    lineage: str = ""

    @property
    def root(self) -> str:
        return self.lineage or self.name


@dataclass(frozen=True)
class Round:
    """One judged optimum: its start, the start's lineage, the update (0: as the start began),
    the optimum, the problem it solves, the judgement, its prior cost [nats], accepted
    iterations and the ledger's work when it was judged."""

    start: str
    root: str
    index: int
    out: Optimized
    problem: PlanningProblem
    verdict: Feasibility
    cost: float
    iterations: int
    work: int


@dataclass
class Ledger:
    """Every judged optimum of a search (``rounds``, in order), the iterations and solver
    trials summed, phase timings [s], the initial error of the first problem at its initial
    trajectory, and the lazy constraints that joined (they hold from the start of every later
    start)."""

    rounds: list[Round] = field(default_factory=list)
    iterations: int = 0
    trials: int = 0
    timings: dict[str, float] = field(default_factory=dict)
    initial_error: float | None = None
    joined: set[str] = field(default_factory=set)

    @property
    def work(self) -> int:
        """Solver trials (linearisations) and judged optima so far."""
        return self.trials + len(self.rounds)

    @property
    def feasible(self) -> Round | None:
        return next((r for r in self.rounds if r.verdict.ok), None)

    @property
    def closest(self) -> Feasibility | None:
        """The judgement that came closest (:meth:`Feasibility.closeness`)."""
        return min((r.verdict for r in self.rounds), key=Feasibility.closeness, default=None)


def prior_cost(problem: PlanningProblem, theta: np.ndarray) -> float:
    """Graph error [nats] of the cost families (the posterior without constraint hinges)."""
    roles = {f.name: f.role for f in problem.families}
    return float(sum(v for name, v in problem.family_errors(theta).items()
                     if roles.get(name, "cost") == "cost"))


def _violation(family: Family, window) -> tuple[np.ndarray, float]:
    """The hinges' current residuals as the new shifts (F, m), and the family's violation:
    the largest max(0, g) [its units] over its residuals."""
    lin = family.residual(window, np.arange(len(family)), jacobians=False)
    shift = np.zeros((len(family), family.dim))
    shift[lin.rows] = lin.error
    before = np.broadcast_to(family.offset(lin.rows), lin.error.shape)
    return shift, float(np.max(lin.error - before, initial=0.0))


def _gives_way(family: Family, window, al: ALConfig) -> Family:
    """A constraint family that holds while another fails: relaxed, its active multipliers
    updated (``al.update_active``)."""
    family = family.relaxed(al.margin_floor) or family
    if al.update_active:
        shift, _ = _violation(family, window)
        if np.any(shift > 0.0):
            family = family.with_shift(shift)
    return family


def update(problem: PlanningProblem, theta: np.ndarray, violated: Iterable[str],
           previous: dict[str, float], lazy: Lazy, al: ALConfig = ALConfig(),
           amounts: Mapping[str, float] | None = None) -> PlanningProblem:
    """The next round's problem starting at theta (T, 2n) (the module docstring's update);
    violated: the families the checks found violated; previous: each family's violation at
    its previous update (updated in place); amounts: the checks' violations by name."""
    violated = set(violated)
    present = {f.name for f in problem.families}
    families = [*problem.families,
                *(lazy[name]() for name in sorted(violated - present) if name in lazy)]
    window = problem.window(theta)
    out = []
    for family in families:
        if family.role != "constraint":
            out.append(family)
        elif family.name not in violated:
            out.append(_gives_way(family, window, al) if violated else family)
        elif family.name not in present:         # joins now, at its configured noise
            out.append(family)
            previous[family.name] = 0.0          # its first update stiffens it
        else:
            shift, violation = _violation(family, window)
            unseen = (amounts or {}).get(family.name, 0.0) - violation
            if unseen > violation:               # the check sees what the hinges do not
                family = family.widened(unseen) or family
            if violation > al.progress * previous.get(family.name, 0.0):
                family = family.reweighted(al.stiffen)
                shift /= al.stiffen ** 2
            previous[family.name] = violation
            out.append(family.with_shift(shift))
    return problem.with_families(out, theta)


def _near(verdict: Feasibility, problem: PlanningProblem, reach: float) -> bool:
    """Whether every check ``verdict`` fails is a constraint family of ``problem`` violated by
    at most ``reach`` times its ``near`` (a hair short of passing)."""
    near = {f.name: reach * float(f.near) for f in problem.families}
    return all(check.name in near and check.amount <= near[check.name]
               for check in verdict.checks if check.violated)


def _amounts(verdict: Feasibility) -> dict[str, float]:
    """The violated checks' amounts by family name."""
    return {check.name: check.amount for check in verdict.checks if check.violated}


def _loose(start: Start, problem: PlanningProblem, config: PlannerConfig, al: ALConfig,
           stop: Callable[[], bool]) -> tuple[PlanningProblem, Optimized | None, WarmStart | None]:
    """The start's problem after its loose first solve (``start.soften``), that solve, and the
    warm-start rule of the first full solve."""
    if start.warm is not None or not start.soften:
        return problem, None, start.warm
    loose = [f.reweighted(1.0 / start.soften[f.name]) if f.name in start.soften else f
             for f in problem.families]
    rule = config.optimizer.stopping_rule().with_(relative_tol=al.soft_tolerance, patience=1)
    soft = optimize(problem.with_families(loose, problem.initial), config.with_(stopping=rule),
                    halt=stop)
    return problem.with_families(problem.families, soft.theta), soft, WarmStart()


def _judged(start: Start, index: int, problem: PlanningProblem, warm: WarmStart | None,
            before: Optimized | None, config: PlannerConfig, judge: Judge,
            ledger: Ledger, stop: Callable[[], bool]) -> Round | None:
    """Solve ``problem`` (after the loose solve ``before``, whose work it counts), judge the
    optimum, write it in the ledger. A solve ``stop`` halted is not judged (None) once the
    ledger holds a judged optimum: the search is out of time, and judging an unfinished solve
    would overrun it by a judgement (a clear optimum's full checks cost 5-10 iterations);
    the first is judged, so a search always has a verdict."""
    out = optimize(problem, config, warm, halt=stop)
    for k, v in out.timings.items():
        ledger.timings[k] = ledger.timings.get(k, 0.0) + v
    iterations = out.iterations + (before.iterations if before else 0)
    ledger.iterations += iterations
    ledger.trials += out.trials + (before.trials if before else 0)
    if ledger.initial_error is None:     # the first problem as asked, at its initial trajectory
        ledger.initial_error = (out.initial_error if before is None
                                else start.problem.error(start.problem.initial))
    if out.stop_reason == HALTED and ledger.rounds:
        return None
    clock = time.perf_counter()
    verdict = judge(out.theta)
    ledger.timings["checks"] = ledger.timings.get("checks", 0.0) + time.perf_counter() - clock
    judged = Round(start.name, start.root, index, out, problem, verdict,
                   prior_cost(problem, out.theta), iterations, ledger.work + 1)
    ledger.rounds.append(judged)
    return judged


def _goes_on(start: Start, judged: Round, polished: int, joins: bool) -> bool:
    """Whether a start whose rounds are spent gets one more update: a polish round while the
    optimum is a hair short (or a lazy constraint the polishing crossed joins)."""
    verdict = judged.verdict
    return (start.rounds > 0 and polished < start.polish and verdict.accepted
            and ((joins and polished > 0) or _near(verdict, judged.problem, start.reach)))


def solve_start(start: Start, config: PlannerConfig, judge: Judge, ledger: Ledger,
                lazy: Lazy | None = None, al: ALConfig = ALConfig(),
                stop: Callable[[], bool] = lambda: False) -> bool:
    """The outer loop on one start (module docstring), every judged optimum written in
    ``ledger``; True when one passes the judge. ``stop()``: checked before every update and
    every solver iteration (e.g. a deadline: the solve stops where it is, and its optimum is
    judged only when it would be the ledger's first); a start that holds no more rounds stops
    by itself."""
    lazy = lazy or {}
    current = start.problem
    carried = [lazy[name]() for name in sorted(ledger.joined) if not current.has(name)]
    if carried:           # a constraint that joined on an earlier start holds from the start
        current = current.with_families([*current.families, *carried], current.initial)
    current, soft, warm = _loose(start, current, config, al, stop)
    previous: dict[str, float] = {}
    index = polished = 0
    while True:
        judged = _judged(start, index, current, warm, soft, config, judge, ledger, stop)
        if judged is None:
            return False
        verdict, soft = judged.verdict, None
        if verdict.ok:
            return True
        if verdict.faulted or not verdict.violated or stop():
            return False          # a refused skill needs another start, not stiffer hinges
        joins = start.rounds > 0 and any(name in lazy and not current.has(name)
                                         for name in verdict.violated)
        if index >= start.rounds and not (joins and index == start.rounds):
            if not _goes_on(start, judged, polished, joins):
                return False
            polished += 1
        ledger.joined.update(name for name in verdict.violated
                             if name in lazy and not current.has(name))
        current = update(current, judged.out.theta, verdict.violated, previous, lazy, al,
                         _amounts(verdict))
        warm, index = WarmStart(), index + 1


def resumed(judged: Round, lazy: Lazy, al: ALConfig = ALConfig()) -> PlanningProblem:
    """The problem that continues ``judged``'s start from its optimum: one more update of its
    multipliers and penalties (as if it had gone on)."""
    return update(judged.problem, judged.out.theta, judged.verdict.violated, {}, lazy, al,
                  _amounts(judged.verdict))


def chosen(ledger: Ledger) -> Round:
    """The plan of a search: its feasible optimum; else one only ``accepted`` refuses (least
    prior cost); else the closest (:meth:`Feasibility.closeness`, then the latest: the most
    updated multipliers)."""
    feasible = [r for r in ledger.rounds if r.verdict.ok]
    if feasible:
        return min(feasible, key=lambda r: r.cost)
    refused = [r for r in ledger.rounds if not r.verdict.violated]
    if refused:
        return min(refused, key=lambda r: r.cost)
    k = min(range(len(ledger.rounds)),
            key=lambda k: (*ledger.rounds[k].verdict.closeness(), -k))
    return ledger.rounds[k]
