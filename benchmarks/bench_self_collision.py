"""Self-collision: cost of checking a plan (robots.self_collision) on the URDF collision
geometry, and of planning with the self-collision hinge (clamp.factors.SelfCollisionFamily).

Run: python benchmarks/bench_self_collision.py  (medians over repeats; never asserts on time).
Plans (T = 250): box_closing (make_demonstrations, 6 demos, seed 0) from the prior's mean
start on the Jaco and the Sawyer, empty scene: the default plan (clear) and the issue-19
reproducer goals (the plan folds the arm into its base). Anchors: the plan itself, and the
obstacle verdict's check of the same plan against box_closing's box
(robots.collision_check.CollisionChecker). Then a plan with the hinge
(epsilon 0.03 m, sigma 0.0005 m, 8 configurations between states) against one without.
"""
from __future__ import annotations

import time

from clamp import learn_prior, plan
from clamp.factors import SelfCollisionFamily
from harness import median_ms, print_environment
from robots import load_robot
from robots.collision_check import CollisionChecker
from robots.self_collision import disabled_pairs, self_collision_report
from scenes import Box, make_demonstrations
from scenes.coal_shapes import coal_obstacles

REPRODUCERS = {"sawyer": [-0.093, 0.107, 0.165], "jaco": [-0.025, -0.05, 0.113]}
BOX = Box.from_reference([0.32, -0.32, 0.13, 0.09, 0.06, 0.28])
REPEATS = 11
HINGE = dict(epsilon=0.03, sigma=0.0005, between=8)


def main() -> None:
    print_environment()
    prior = learn_prior(make_demonstrations("box_closing", num_demos=6, seed=0))
    start = prior.mean[0, :3]
    print("\n## checking a plan (median ms over", REPEATS, "runs)")
    print(f"{'arm':7s} {'plan':10s} {'collision':>9s} {'min mm':>8s} {'K':>5s} {'hull':>5s} {'exact':>5s} "
          f"{'self ms':>8s} {'plan ms':>8s} {'obstacle ms':>11s} {'self/plan':>9s} {'self/obstacle':>13s}")
    for name in ("jaco", "sawyer"):
        robot = load_robot(name)
        begin = time.perf_counter()
        disabled_pairs(robot)
        print(f"# {name}: disabled pairs computed once in {time.perf_counter() - begin:.2f} s "
              f"({len(disabled_pairs(robot))} pairs)")
        obstacle = CollisionChecker(robot, coal_obstacles([BOX]))
        for label, goal in (("default", None), ("reproducer", REPRODUCERS[name])):
            result = plan(prior, robot, None, start, goal=goal)
            plan_ms = median_ms(lambda: plan(prior, robot, None, start, goal=goal), 3)
            report = self_collision_report(robot, result.q, prior.time)
            self_ms = median_ms(lambda: self_collision_report(robot, result.q, prior.time), REPEATS)
            obstacle_ms = median_ms(lambda: obstacle.check(result.q, prior.time), REPEATS)
            print(f"{name:7s} {label:10s} {str(report.collision):>9s} {1e3 * report.min_distance:8.1f} "
                  f"{report.num_configurations:5d} {report.num_hull:5d} {report.num_exact:5d} {self_ms:8.1f} "
                  f"{plan_ms:8.1f} {obstacle_ms:11.1f} {self_ms / plan_ms:9.2f} {self_ms / obstacle_ms:13.2f}")

    print("\n## planning with the hinge", HINGE, "(one run each; ratio against the plan without it)")
    print(f"{'arm':7s} {'plan':10s} {'without ms':>10s} {'with ms':>8s} {'ratio':>6s} {'success':>7s} "
          f"{'self-collision':>14s} {'min mm':>7s}")
    for name in ("jaco", "sawyer"):
        robot = load_robot(name)
        family = SelfCollisionFamily.for_robot(robot, range(prior.T - 1), **HINGE)
        for label, goal in (("default", None), ("reproducer", REPRODUCERS[name])):
            begin = time.perf_counter()
            plan(prior, robot, None, start, goal=goal)
            without = 1e3 * (time.perf_counter() - begin)
            begin = time.perf_counter()
            result = plan(prior, robot, None, start, goal=goal, extra_factors=[family])
            with_ = 1e3 * (time.perf_counter() - begin)
            report = self_collision_report(robot, result.q, prior.time)
            print(f"{name:7s} {label:10s} {without:10.0f} {with_:8.0f} {with_ / without:6.1f} "
                  f"{str(result.success):>7s} {str(report.collision):>14s} {1e3 * report.min_distance:7.1f}")


if __name__ == "__main__":
    main()
