"""Report: goals, via points and tool orientation met, with the plans' plausibility.

box_closing (synthetic, seed 0), README start, Jaco and Sawyer: the goal moved 5 cm in each of
6 directions (empty scene), and a via point 3 cm off the prior mean (+x) at mid-trajectory;
each miss is measured with our own forward kinematics, with the plausibility of the plan
(clamp.prior.plausibility, conditioned on start / goal / via: it scores the motion given the
targets, not the targets themselves; how far the goal lies from the prior's end is printed in
standard deviations of the end marginal) and, for comparison, the miss of the
soft goal factor alone (condition_on_targets=False). Then the tool z within 5 deg of straight
down over the last 40 % of the states in the README's box scene (warm-started from the
empty-scene plan), its largest angle, clearance and the angle figure (--out directory).

Run: python benchmarks/report_targets.py [--out DIR]
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from clamp import PlannerConfig, learn_prior, plan
from clamp.factors import OrientationFamily
from clamp.viz.plan_plots import plot_orientation
from robots import load_robot
from scenes import Box, Scene, make_demonstrations

START = [0.2054, -0.4722, 0.2625]
BOX = Box.from_reference([0.32, -0.32, 0.13, 0.09, 0.06, 0.28])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out")
    args = parser.parse_args()
    prior = learn_prior(make_demonstrations("box_closing", num_demos=6, seed=0))
    soft = PlannerConfig().with_(condition_on_targets=False)
    mid = prior.T // 2
    for arm in ("jaco", "sawyer"):
        robot = load_robot(arm)
        print(f"{arm}: goal moved 5 cm -> miss [mm] (plausibility; soft goal factor alone: miss)")
        for axis in range(3):
            for sign in (1.0, -1.0):
                goal = prior.mean[-1, :3].copy()
                goal[axis] += sign * 0.05
                result = plan(prior, robot, None, START, goal, covariance=False)
                old = plan(prior, robot, None, START, goal, covariance=False, config=soft)
                miss = 1e3 * np.linalg.norm(robot.fk(result.q[-1]) - goal)
                old_miss = 1e3 * np.linalg.norm(robot.fk(old.q[-1]) - goal)
                offset = goal - prior.mean[-1, :3]
                sigmas = float(np.sqrt(offset @ np.linalg.solve(prior.cov[-1, :3, :3], offset)))
                print(f"  {'+' if sign > 0 else '-'}{'xyz'[axis]}: {miss:7.4f} mm "
                      f"(plausibility {result.plausibility:.3f}, z {result.plausibility_z:.2f}, "
                      f"success {result.success}; goal {sigmas:.0f} sigma from the prior's "
                      f"end; soft: {old_miss:5.1f} mm)")
        via = prior.mean[mid, :3] + [0.03, 0.0, 0.0]
        result = plan(prior, robot, None, START, via_points=[(mid, via)], covariance=False)
        miss = 1e3 * np.linalg.norm(robot.fk(result.q[mid]) - via)
        print(f"  via point +3 cm x at state {mid}: {miss:7.4f} mm (plausibility "
              f"{result.plausibility:.3f}, z {result.plausibility_z:.2f}, success "
              f"{result.success})")
        down = OrientationFamily.window(prior.T, 0.4, axis=[0, 0, 1], direction=[0, 0, -1],
                                        tolerance=np.radians(5.0))
        free = plan(prior, robot, None, START, extra_factors=[down], covariance=False)
        result = plan(prior, robot, Scene([BOX]), START, extra_factors=[down],
                      covariance=False, initial=np.hstack([free.q, free.qdot]))
        single = plan(prior, robot, Scene([BOX]), START, extra_factors=[down], covariance=False)
        angle = np.degrees(down.angles(robot, result.q)).max()
        path = Path(args.out) / f"orientation_{arm}.png"
        plot_orientation(result, robot, down, path=path)
        print(f"  tool z within 5 deg of down over the last 40 %: largest {angle:.2f} deg, "
              f"clearance {1e3 * result.min_clearance:.1f} mm, success {result.success}, "
              f"plausibility {result.plausibility:.3f} (one solve without the warm start: "
              f"success {single.success}, clearance {1e3 * single.min_clearance:.1f} mm); "
              f"figure {path}")


if __name__ == "__main__":
    main()
