"""Benchmark of replanning (clamp.replan) against a fresh plan, box_closing in the README's box
scene, README start, Jaco and Sawyer.

Cases: the goal moved 5 cm (y) and the box moved 5 cm (y; moved 5 cm in x it blocks the
Sawyer: a fresh plan collides, see the note of issue 12). For each: a fresh ``plan`` of the
changed request (anchor), ``replan`` from the previous plan with the previous (default)
configuration, and ``replan`` with ``PlannerConfig.fast()`` (a step decreasing the error by
less than 5 % stops); all with covariance=False (the posterior covariance costs the same either
way). The three are timed interleaved (one call of each per round) so load drifts on a shared
machine hit all alike. Prints median wall times, iterations, the ratio replan / fresh (target
<= 0.35, issue 27) and the checks: success, clearance, goal error and the largest distance of the
replanned end-effector path from the fresh plan's.
With ``--isam2`` also times GTSAM's ISAM2 on the problem's graph (Python factor adapters):
one update from the previous plan, then relinearising updates.

Figures (2026-11-27, 2 shared cores, load 4.2-4.4, 15 repeats; main c3e6427 and branch replan
run back to back twice, both runs shown), ratio replan / fresh, default config / ``fast()``:

    case            main (c3e6427)          replan branch           path from fresh [mm]
    Jaco goal       0.83 / 0.75, 0.87 / 0.73  0.70 / 0.60, 0.67 / 0.58  0.065 / 0.079 -> 0.000 / 0.000
    Jaco box        0.48 / 0.55, 0.49 / 0.55  0.48 / 0.48, 0.49 / 0.48  0.011 / 0.011 (unchanged)
    Sawyer goal     0.87 / 0.77, 0.86 / 0.77  0.83 / 0.76, 0.83 / 0.76  0.052 / 0.012 -> 0.111 / 0.112
    Sawyer box      0.35 / 0.51, 0.34 / 0.49  0.34 / 0.29, 0.35 / 0.29  0.470 / 1.551 -> 0.470 / 0.470

What changed: a moved goal moves the previous conditioned prior (no conditioning again), solves
the new free plan from the previous one moved to the new goal and starts the tied solve where
that leaves the previous plan (at the new free plan when the previous plan was its free plan:
no tied step); the free plan is reused whenever the free problem is the same (``fast()`` after
a moved box). The 0.35 target is met by the Sawyer box only. Where the rest goes (Jaco goal
moved, ~22 ms): the free plan solved to the configured tolerances (~9 ms, 3 iterations: it
cannot stop earlier without leaving the Jaco's wrist elsewhere in directions the empty scene
hardly constrains, see clamp.planning.assembly.free_plan), the real-geometry checks (~6.4
ms: obstacles ~3.3, self-collision ~3.1, the same as a fresh plan's), the tied solve's
convergence check (~3.4 ms, one linearization); box moved: 2 solver iterations and their
convergence check (~11 ms) and the checks (~7.7 ms).

Figures (2026-11-29, branch time: the time scale chosen before the path solve; 2 shared cores,
load 10.9-12.7, 5 repeats; absolute times are ~25x a quiet machine's, read the ratios), ratio
replan / fresh, default config / ``fast()``, path from fresh [mm]:

    Jaco goal       0.61 / 0.62   0.000 / 0.000
    Jaco box        0.45 / 0.36   0.011 / 0.011
    Sawyer goal     0.66 / 0.65   0.191 / 0.253
    Sawyer box      0.29 / 0.24   0.465 / 0.465

Every replan succeeds, paths within 0.5 mm of the fresh plans' (target 2 mm); the 0.35 target
is met by the Sawyer box only, as before: a replan's time is its free plan and its checks
(above), which the time stage does not change (a replan keeps the previous plan's scale).

Run: python benchmarks/bench_replan.py [--repeats 9] [--isam2]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from clamp import PlannerConfig, build, learn_prior, plan, replan
from harness import interleaved_median_seconds, print_environment
from robots import load_robot
from scenes import Box, Scene, make_demonstrations

START = [0.2054, -0.4722, 0.2625]
BOX = Box.from_reference([0.32, -0.32, 0.13, 0.09, 0.06, 0.28])


def isam2_seconds(prior, robot, scene, goal, previous, updates: int = 5) -> tuple[float, float]:
    """Seconds of GTSAM ISAM2: the first update (graph + previous plan as values) and then
    ``updates`` relinearising updates; returns (first, total)."""
    import gtsam
    problem = build(prior, robot, scene, START, goal, initial=np.hstack([previous.q,
                                                                          previous.qdot]))
    graph, values = problem.graph(), problem.values()
    params = gtsam.ISAM2Params()
    params.setRelinearizeThreshold(1e-3)
    params.setFactorization("QR")       # Cholesky: "indeterminate linear system" near x0
    isam = gtsam.ISAM2(params)
    t0 = time.perf_counter()
    isam.update(graph, values)
    first = time.perf_counter() - t0
    for _ in range(updates):
        isam.update()
    return first, time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=9)
    parser.add_argument("--isam2", action="store_true")
    args = parser.parse_args()
    print_environment()
    prior = learn_prior(make_demonstrations("box_closing", num_demos=6, seed=0))
    scene = Scene([BOX])
    moved_scene = Scene([BOX.translated([0.0, 0.05, 0.0])])
    goal = prior.mean[-1, :3]
    moved_goal = goal + [0.0, 0.05, 0.0]
    print(f"median of {args.repeats} runs, covariance=False; ratio = replan / fresh")
    for arm in ("jaco", "sawyer"):
        robot = load_robot(arm)
        previous = plan(prior, robot, scene, START, goal, covariance=False)
        cases = (("goal moved 5 cm", dict(goal=moved_goal), (scene, moved_goal)),
                 ("box moved 5 cm", dict(scene=moved_scene), (moved_scene, goal)))
        for name, change, (new_scene, new_goal) in cases:
            configs = {"replan, same config": None, "replan, PlannerConfig.fast()":
                       PlannerConfig.fast()}
            calls = {"fresh": lambda: plan(prior, robot, new_scene, START, new_goal,
                                           covariance=False)}
            calls.update({label: (lambda c=config: replan(previous, config=c, covariance=False,
                                                          **change))
                          for label, config in configs.items()})
            results = {label: call() for label, call in calls.items()}
            seconds = interleaved_median_seconds(calls, args.repeats)
            fresh, fresh_result = seconds["fresh"], results["fresh"]
            print(f"{arm}, {name}: fresh plan {1e3 * fresh:7.1f} ms "
                  f"({fresh_result.iterations} it, success {fresh_result.success})")
            for label in configs:
                result = results[label]
                apart = np.abs(result.ee_path - fresh_result.ee_path).max()
                print(f"    {label:30s} {1e3 * seconds[label]:7.1f} ms ({result.iterations} it, "
                      f"success {result.success}, clearance {1e3 * result.min_clearance:.1f} "
                      f"mm, goal error {1e3 * (result.goal_error or 0):.3f} mm, path within "
                      f"{1e3 * apart:.3f} mm of fresh)  ratio {seconds[label] / fresh:.2f}")
            if args.isam2:
                first, total = isam2_seconds(prior, robot, new_scene, new_goal, previous)
                print(f"    GTSAM ISAM2 first update {1e3 * first:7.1f} ms, +5 updates "
                      f"{1e3 * total:7.1f} ms  ratio {total / fresh:.2f}")


if __name__ == "__main__":
    main()
