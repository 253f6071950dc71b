"""Third-party arms: a box placed in the skill's path, default settings.

Run: python benchmarks/bench_arms.py  (prints; never asserts on time). The skill: box_closing
(6 synthetic demonstrations, seed 0), started at the prior's mean start. Arms: the Jaco (anchor)
and four URDFs shipped by example-robot-data, loaded with ``Robot.from_urdf`` (collision spheres
fitted automatically): Franka Panda, UR5, Unitree Z1, xArm7. For each arm, the empty-scene plan,
then a 5 cm cube centred on that plan's end-effector path half way along it: the default plan
(collision-free as a constraint) and the weighted solve alone (``constraint_rounds=0``, what
the planner did before). Collision-freeness is the verdict's (URDF collision meshes, coal, at
and between states); "brute" re-checks it with coal on every link-obstacle pair at the states
and segment midpoints. Times are medians of 3 calls (after a warm-up that fits the spheres and
builds the convex hulls), on a shared machine: noisy.
"""
from __future__ import annotations

import time

import numpy as np

from clamp import PlannerConfig, learn_prior, plan
from harness import median_ms, print_environment
from robots import Robot, load_robot
from robots.collision_check import CollisionChecker
from robots.registry import example_robot_data_share
from scenes import Box, Scene, make_demonstrations
from scenes.coal_shapes import coal_obstacles

ARMS = {"panda": ("panda_description/urdf/panda.urdf", "panda_hand"),
        "ur5": ("ur_description/urdf/ur5_robot.urdf", "tool0"),
        "z1": ("z1_description/urdf/z1.urdf", "link06"),
        "xarm7": ("xarm_description/urdf/xarm7.urdf", "link7")}


def brute_clearance(robot: Robot, scene: Scene, q: np.ndarray) -> float:
    """coal on every link-obstacle pair at the states of q (T, n) and the segment midpoints."""
    dense = np.concatenate([q, 0.5 * (q[1:] + q[:-1])])
    return float(CollisionChecker(robot, coal_obstacles(scene)).distances(dense).min())


def main() -> None:
    print_environment()
    prior = learn_prior(make_demonstrations("box_closing", num_demos=6, seed=0))
    start = prior.mean[0, :3]
    share = example_robot_data_share()
    robots = {"jaco": load_robot("jaco")}
    for name, (path, ee) in ARMS.items():
        urdf = share / "example-robot-data" / "robots" / path
        robots[name] = Robot.from_urdf(urdf, end_effector=ee, package_dirs=[share])
    weighted = PlannerConfig().with_(constraint_rounds=0)
    print(f"{'arm':7s} {'n':>2s} {'empty ms':>9s} | {'default':>8s} {'brute mm':>9s} {'ms':>6s} "
          f"{'attempts':>8s} | {'weighted only':>14s} {'ms':>6s} | nearest link (default)")
    avoided = 0
    for name, robot in robots.items():
        empty = plan(prior, robot, None, start=start, covariance=False)
        if not empty.success:
            print(f"{name:7s} empty-scene plan failed: {empty.reasons}")
            continue
        scene = Scene([Box(empty.ee_path[len(empty.ee_path) // 2], [0.05, 0.05, 0.05])])
        first = time.perf_counter()
        plan(prior, robot, scene, start=start, covariance=False)          # warm-up: spheres, hulls
        warm_s = time.perf_counter() - first
        empty_ms = median_ms(lambda: plan(prior, robot, None, start=start, covariance=False), 3)
        results = {}
        default_ms = median_ms(lambda: results.__setitem__(
            "default", plan(prior, robot, scene, start=start, covariance=False)), 3, warmup=0)
        weighted_ms = median_ms(lambda: results.__setitem__(
            "weighted", plan(prior, robot, scene, start=start, covariance=False,
                             config=weighted)), 3, warmup=0)
        result, alone = results["default"], results["weighted"]
        brute = brute_clearance(robot, scene, result.q)
        avoided += bool(result.success and brute > 0.0)
        weighted_text = "ok" if alone.success else f"{alone.stop_reason} {alone.min_clearance * 1e3:+.1f}mm"
        print(f"{name:7s} {robot.n:2d} {empty_ms:9.0f} | {str(result.success):>8s} {brute * 1e3:9.1f} "
              f"{default_ms:6.0f} {len(result.attempts):8d} | {weighted_text:>14s} {weighted_ms:6.0f} | "
              f"{result.nearest_contact['link']} ({result.collision_geometry}; first call {warm_s:.1f} s)")
        if not result.success:
            print(f"        reasons: {result.reasons}")
    print(f"box in the path avoided at default settings: {avoided}/{len(robots)} arms")


if __name__ == "__main__":
    main()
