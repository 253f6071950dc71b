"""Collision-free as a constraint: penalty continuation on the obstacle hinge, with restarts.

The learned prior is nearly rigid given the start (per-step noise of micrometres), so no fixed
obstacle weight suits every scene. :func:`solve_collision_free` treats "no collision" (measured
on the robot's own collision geometry, :mod:`clamp.clearance`) as a constraint:

1. solve the problem as configured (obstacle hinge noise ``sigma_obs``); a collision-free plan
   is returned as it is (one real-geometry check, which the verdict reuses). A fresh plan
   (no warm start) whose initial trajectory runs through an obstacle (a collision sphere
   penetrates one) is solved in two stages, a penalty schedule: first with the hinge noise
   multiplied by ``config.optimizer.soft_start`` and a loose stopping rule
   (:data:`SOFT_START_TOLERANCE`, one small step), then at ``sigma_obs`` from there with the
   solver's warm-start rule. Soft hinges let the path slide around an obstacle before the stiff
   ones pin it (box_closing + box on the Jaco: 43 -> 8 iterations; on 25 random boxes 29 %
   fewer iterations on the Jaco, 13 % on the Sawyer; on 48 scene-benchmark problems per arm,
   each planned both ways: total time -15 % on both arms, p90 -19 % / -38 %, median +9 % /
   +6 % (Jaco / Sawyer); final errors lower or higher case by case: another local optimum);
2. otherwise run candidates, each a penalty continuation: solve with the hinge noise multiplied
   by ``SHRINK`` per round (``rounds`` rounds at most, each warm-started from the last), stop
   at the first collision-free solution. The candidates, in order: the infeasible optimum
   itself (from round 1), then the restarts the caller gives (e.g. detours of the prior mean
   around the offending obstacle, a straight line in joint space; from round 0). Once one
   candidate is collision-free at round r, the others get one solve each, at round r (cheap:
   the restarts only compete, they do not search);
3. stop once ``WANTED`` candidates are collision-free and keep the one with the best prior cost
   (graph error without the obstacle hinges); when none is, return the one that comes
   closest, with ``stop_reason`` "infeasible" (never "converged"): the report names the link,
   obstacle, state and depth of the remaining collision.

4. :func:`tighten_constraints`: the other soft constraints (joint-limit hinges, constraint
   families such as orientation) are hinges too; while the chosen optimum violates one as the
   verdict judges it, re-solve from it (the solver's warm-start rule) with that family's noise
   divided by 1 / ``SHRINK`` more each round, keeping the obstacle weight that made it
   collision-free; a round that brings back a collision is not taken.

Every candidate calls the configured optimizer (:func:`clamp.optimizers.optimize`) on a problem
that differs from the original only by the obstacle hinge's noise.
"""
from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from itertools import chain

import numpy as np

from clamp.config import PlannerConfig
from clamp.factors import ObstacleFamily, PostureFamily
from clamp.initialisation import joint_velocities
from clamp.optimizers import Optimized, optimize
from clamp.problem import PlanningProblem
from clamp.solver import WarmStart
from robots.collision_check import CollisionReport

log = logging.getLogger(__name__)

#: factor applied to the obstacle hinge noise each continuation round (4x stiffer per round)
SHRINK = 0.25
#: collision-free candidates after which the restarts stop
WANTED = 2
#: relative error decrease below which the soft-start stage stops (after one such step; 3e-2
#: took fewer iterations than 1e-2 and 3e-3 on box_closing with random boxes, both arms)
SOFT_START_TOLERANCE = 3e-2

Check = Callable[[np.ndarray], CollisionReport]
#: names of the soft constraint families a plan theta (T, 2n) violates
Violated = Callable[[np.ndarray], list[str]]
Restarts = Callable[[CollisionReport], Iterable[tuple[str, np.ndarray]]]


@dataclass(frozen=True)
class Attempt:
    """One solve: the candidate's name, the hinge noise sigma [m], the real-geometry minimum
    distance [m] of its optimum, whether it is collision-free, its prior cost [nats] (graph
    error without the obstacle hinges) and accepted iterations."""

    candidate: str
    sigma: float
    min_distance: float
    feasible: bool
    prior_cost: float
    iterations: int


@dataclass(frozen=True)
class ConstrainedSolve:
    """The chosen optimum (``out``; iterations and trials summed over every attempt, initial and
    final error those of the problem as asked, at ``sigma_obs``), its
    real-geometry report and every attempt made (the first is the configured solve)."""

    out: Optimized
    report: CollisionReport
    attempts: list[Attempt]
    #: [m] the obstacle hinge noise of the problem the chosen optimum solves
    sigma: float


def reweighted(problem: PlanningProblem, factors: dict[str, float], initial: np.ndarray
               ) -> PlanningProblem:
    """The same problem with the noise of the families named in ``factors`` divided by their
    factor (:meth:`clamp.factors.Family.reweighted`), starting at initial (T, 2n)."""
    families = [f.reweighted(factors[f.name]) if f.name in factors else f
                for f in problem.families]
    return problem.with_families(families, initial)


def with_obstacle_sigma(problem: PlanningProblem, sigma: float, initial: np.ndarray
                        ) -> PlanningProblem:
    """The same problem with the obstacle hinges' noise set to sigma [m], starting at initial
    (T, 2n). Stiffer hinges loosen the posture tie (:class:`~clamp.factors.PostureFamily`) by
    the same factor: the continuation's later rounds free the arm to leave the free plan's
    posture when keeping it collides."""
    current = 1.0 / float(problem.family(ObstacleFamily.name).whitening[0])
    factors = {ObstacleFamily.name: current / sigma}
    if sigma < current and problem.has(PostureFamily.name):
        factors[PostureFamily.name] = sigma / current
    return reweighted(problem, factors, initial)


def _prior_cost(problem: PlanningProblem, theta: np.ndarray) -> float:
    return float(sum(v for name, v in problem.family_errors(theta).items()
                     if name != ObstacleFamily.name))


def solve_collision_free(problem: PlanningProblem, config: PlannerConfig, check: Check,
                         restarts: Restarts, rounds: int,
                         warm_start: WarmStart | None = None,
                         accept: Callable[[np.ndarray], bool] | None = None) -> ConstrainedSolve:
    """Optimise ``problem`` (which has an obstacle family) until ``check(theta)`` finds no
    collision (see the module docstring); rounds: continuation rounds per candidate (0: the
    configured solve only); warm_start: the solver's warm-start rule for the configured solve
    (its initial trajectory is a previous plan, :func:`clamp.replan`), never for the others;
    accept(theta) -> bool: what else a solution must meet to count as feasible (the skill
    checks): a collision-free solution it refuses sends the loop on to the restarts too."""
    sigma0 = float(config.model.sigma_obs)
    attempts: list[Attempt] = []
    solved: list[tuple[Optimized, CollisionReport, float, float]] = []
    totals = {"iterations": 0, "trials": 0, "clearance": 0.0}

    def attempt(name: str, sigma: float, theta0: np.ndarray, warm: WarmStart | None = None,
                before: Optimized | None = None) -> tuple[Optimized, CollisionReport]:
        """Solve at sigma from theta0 (after the stage ``before``, whose work it counts)."""
        out = optimize(with_obstacle_sigma(problem, sigma, theta0), config, warm)
        if before is not None:
            out = replace(out, iterations=out.iterations + before.iterations,
                          trials=out.trials + before.trials,
                          initial_error=problem.error(problem.initial),
                          timings={k: v + before.timings.get(k, 0.0)
                                   for k, v in out.timings.items()})
        started = time.perf_counter()
        report = check(out.theta)
        totals["clearance"] += time.perf_counter() - started
        cost = _prior_cost(problem, out.theta)
        totals["iterations"] += out.iterations
        totals["trials"] += out.trials
        ok = not report.collision and (accept is None or accept(out.theta))
        attempts.append(Attempt(name, sigma, float(report.min_distance), ok, cost,
                                out.iterations))
        solved.append((out, report, cost, sigma, ok))
        return out, report, ok

    start = time.perf_counter()
    theta0, soft = problem.initial, None
    factor = float(config.optimizer.soft_start)
    obstacles = problem.family(ObstacleFamily.name)
    if (warm_start is None and factor > 1.0
            and obstacles.penetration(problem.window(theta0)) > 0.0):
        soft = optimize(with_obstacle_sigma(problem, sigma0 * factor, theta0),
                        config.with_(relative_error_tol=SOFT_START_TOLERANCE,
                                     convergence_patience=1))
        theta0, warm_start = soft.theta, WarmStart()
    out, report, ok = attempt("configured", sigma0, theta0, warm_start, soft)
    if not ok and report.fault is None and rounds > 0:     # a failed check: nothing to repair
        # the optimum continued first; the restarts run only while fewer than WANTED
        # candidates are feasible, and once one is, only at the weight that made it feasible
        # stiffer hinges only help a collision; a plan refused by ``accept`` alone needs
        # another way around
        candidates = chain([("continuation", out.theta, 1)] if report.collision else [],
                           ((name, theta, 0) for name, theta in restarts(report)))
        first_ok = None
        for name, theta, k in candidates:
            if sum(s[4] for s in solved) >= WANTED:
                break
            first = k if first_ok is None else first_ok
            last = rounds if first_ok is None else first_ok
            for r in range(first, last + 1):
                out, report, ok = attempt(name, sigma0 * SHRINK ** r, theta)
                if ok:
                    first_ok = r if first_ok is None else first_ok
                    break
                theta = out.theta
    feasible = [s for s in solved if s[4]]
    clear = [s for s in solved if not s[1].collision]
    if feasible:
        best, report, _, sigma, _ = min(feasible, key=lambda s: s[2])
        stop = best.stop_reason
    elif clear:           # collision-free but refused by ``accept``: the verdict says why
        best, report, _, sigma, _ = min(clear, key=lambda s: s[2])
        stop = "infeasible"
    else:
        best, report, _, sigma, _ = max(solved, key=lambda s: s[1].min_distance)
        stop = "infeasible"
        if len(solved) > 1:
            log.info("no collision-free plan after %d attempts; the closest still penetrates "
                     "%.1f mm", len(solved), -1e3 * report.min_distance)
    timings = dict(best.timings)
    timings["constraint_loop"] = time.perf_counter() - start
    timings["clearance"] = totals["clearance"]
    # errors of the problem as asked (sigma_obs), whichever weight found the chosen optimum
    chosen = replace(best, iterations=totals["iterations"], trials=totals["trials"],
                     stop_reason=stop, timings=timings,
                     initial_error=solved[0][0].initial_error,
                     final_error=best.final_error if best is solved[0][0]
                     else problem.error(best.theta))
    return ConstrainedSolve(chosen, report, attempts, sigma)


def tighten_constraints(problem: PlanningProblem, base: PlanningProblem, out: Optimized,
                        config: PlannerConfig, violated: Violated, check: Check | None,
                        rounds: int, report: CollisionReport | None = None,
                        sigma: float = float("nan")) -> tuple[Optimized, CollisionReport | None,
                                                              list[Attempt]]:
    """Re-solve ``out`` (the optimum of ``base``, e.g. ``problem`` with stiffer obstacle
    hinges of noise ``sigma`` [m]) while ``violated(theta)`` names families (see the module
    docstring, step 4); check: the real-geometry collision check (None without obstacles),
    report: its result for ``out``. Returns the chosen optimum (iterations and trials summed,
    errors those of ``problem`` as asked), its report and the attempts made."""
    started = time.perf_counter()
    factors: dict[str, float] = {}
    attempts: list[Attempt] = []
    best, best_report = out, report
    iterations, trials = out.iterations, out.trials
    for _ in range(rounds):
        names = violated(best.theta)
        if not names:
            break
        for name in names:
            factors[name] = factors.get(name, 1.0) / SHRINK
        new = optimize(reweighted(base, factors, best.theta), config, WarmStart())
        iterations, trials = iterations + new.iterations, trials + new.trials
        new_report = check(new.theta) if check is not None else None
        collides = new_report is not None and new_report.collision
        attempts.append(Attempt("tightened " + "+".join(f"{k} x{v:g}" for k, v in factors.items()),
                                sigma, math.inf if new_report is None
                                else float(new_report.min_distance), not collides,
                                _prior_cost(problem, new.theta), new.iterations))
        if collides and not (best_report is not None and best_report.collision):
            log.info("tightening %s brought back a collision: kept the plan before it",
                     ", ".join(names))
            break
        best, best_report = new, new_report
    if best is out:
        return out, report, attempts
    timings = dict(out.timings)
    timings["constraints"] = time.perf_counter() - started
    chosen = replace(best, iterations=iterations, trials=trials, timings=timings,
                     initial_error=out.initial_error, final_error=problem.error(best.theta))
    return chosen, best_report, attempts


def detour_paths(path: np.ndarray, centre: np.ndarray, radius: float, clearance: float,
                 index: float) -> list[tuple[str, np.ndarray]]:
    """End-effector paths (T, 3) [m] that leave ``path`` (T, 3) around an obstacle (bounding
    sphere ``centre`` (3,), ``radius`` [m]) met near state ``index``: "detour_away" pushes the
    path away from the centre across its direction of travel, "detour_over" lifts it (+z), each
    by radius + clearance at the contact, faded in and out (raised cosine) over the states within
    radius + 2 clearance of the centre (at least a tenth of the path each side)."""
    T = len(path)
    i = int(np.clip(round(index), 0, T - 1))
    near = np.flatnonzero(np.linalg.norm(path - centre, axis=1) < radius + 2.0 * clearance)
    half = max(T // 10, int(np.max(np.abs(near - i))) if near.size else 0, 1)
    s = np.clip((np.arange(T) - i) / half, -1.0, 1.0)
    window = 0.5 * (1.0 + np.cos(np.pi * s))
    window[0] = 0.0                                   # the start stays where it was asked
    tangent = path[min(i + 1, T - 1)] - path[max(i - 1, 0)]
    tangent /= max(np.linalg.norm(tangent), 1e-12)
    away = path[i] - centre
    away -= tangent * (away @ tangent)
    if np.linalg.norm(away) < 1e-9:
        away = np.cross(tangent, [0.0, 0.0, 1.0])
        if np.linalg.norm(away) < 1e-9:
            away = np.array([1.0, 0.0, 0.0])
    away /= np.linalg.norm(away)
    amplitude = radius + clearance
    out = []
    for name, direction in (("detour_away", away), ("detour_over", np.array([0.0, 0.0, 1.0]))):
        out.append((name, path + amplitude * window[:, None] * direction))
    return out


def bounding_sphere(obstacle) -> tuple[np.ndarray, float]:
    """Centre (3,) and radius [m] of a ball containing a scene obstacle (from its AABB)."""
    box = np.asarray(obstacle.aabb(), dtype=float)
    return 0.5 * (box[0] + box[1]), 0.5 * float(np.linalg.norm(box[1] - box[0]))


def detour_restarts(robot, path: np.ndarray, q_start: np.ndarray, dt: float, obstacle,
                    clearance: float, index: float, tolerance: float
                    ) -> Iterable[tuple[str, np.ndarray]]:
    """Joint-state trajectories (T, 2n) of :func:`detour_paths` around ``obstacle`` (a scene
    obstacle met near state ``index``), by inverse kinematics seeded at q_start (n,); generated
    lazily (each costs an IK of the path)."""
    centre, radius = bounding_sphere(obstacle)
    for name, detour in detour_paths(path, centre, radius, clearance, index):
        q = np.array(robot.ik_trajectory(detour, seed=q_start, tol=tolerance).q, dtype=float)
        q[0] = q_start
        yield name, np.concatenate([q, joint_velocities(q, dt)], axis=1)
