"""Verdict geometry: cost of checking a plan on the Jaco's URDF collision meshes
(robots.collision_check) against the cost of making the plan.

Run: python benchmarks/bench_collision_check.py [--problems 12]  (medians over repeats; never
asserts on time).
The plan: box_closing demonstrations (../shared/datasets/box_closing.mat), Jaco, start
[0.2054, -0.4722, 0.2625], the box [0.32, -0.32, 0.13, 0.09, 0.06, 0.28] (T = 250).
Also: the same trajectory against five more obstacles (seeded), and what coal's own mesh
distance (pin.computeDistances on every link-obstacle pair) costs per support state. Every
distance the checker uses is a coal query: num_hull on convex hulls (of whole meshes and of
their pieces; GJK, a few microseconds), num_exact on the geometry itself (primitives, mesh
leaves of at most PIECE_TRIANGLES triangles).

Then the verdict inside plan() on scene-benchmark problems (clamp.batch.problem_sets.scene_benchmark,
200 problems, seed 21, 1-4 obstacles; the two named problems 11 and 155 of the Jaco, which took
24 s and 5.8 s with 20.9 s and 5.7 s in the check before pieces, and --problems more per arm,
evenly spread), twice (first pass: mesh pieces built as they are first needed; again: built):
every check's time, the largest, and the check's share of plan time (median, p99; all
problems and the feasible ones: an impossible one fails after checking its start alone). And the
broad phase: the same trajectory against 10,000 obstacles, a few near the arm and the rest far,
against the near ones alone (the anchor).
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from clamp import learn_prior, plan
from harness import median_ms, print_environment, shared_demonstrations
from robots import load_robot
from robots.collision_check import CollisionChecker
from scenes import Box, Capsule, Cylinder, Scene, Sphere
from scenes.coal_shapes import coal_obstacles

START = np.array([0.2054, -0.4722, 0.2625])
BOX = Box.from_reference([0.32, -0.32, 0.13, 0.09, 0.06, 0.28])
REPEATS = 21


def extra_obstacles(path: np.ndarray, seed: int = 0) -> list:
    """Four obstacles 6-12 cm off the end-effector path (a box, a sphere, a cylinder, a capsule)."""
    rng = np.random.default_rng(seed)
    points = path[rng.choice(len(path), 4, replace=False)]
    offsets = rng.normal(size=(4, 3))
    offsets *= rng.uniform(0.06, 0.12, (4, 1)) / np.linalg.norm(offsets, axis=1, keepdims=True)
    c = points + offsets
    return [Box(c[0], [0.04, 0.03, 0.05]), Sphere(c[1], 0.03), Cylinder(c[2], 0.02, 0.1, rng.normal(size=3)),
            Capsule(c[3], 0.02, 0.08, rng.normal(size=3))]


def verdict_share(count: int) -> None:
    """Check time per plan() on scene-benchmark problems (see the module docstring)."""
    from clamp.batch import problem_sets
    from clamp.batch.runner import resolve
    from robots import collision_check
    checks: list[float] = []
    record = collision_check.CollisionChecker.check

    def timed(self, *args, **kwargs):
        report = record(self, *args, **kwargs)
        checks.append(report.timings["total"])
        return report

    collision_check.CollisionChecker.check = timed
    try:
        for arm in ("jaco", "sawyer"):
            problems = problem_sets.scene_benchmark(200, arm, seed=21, obstacles=(1, 4))
            chosen = sorted(set(np.linspace(0, len(problems) - 1, count).astype(int).tolist())
                            | ({11, 155} if arm == "jaco" else set()))
            robot = resolve(problems[0], Path("."))["robot"]
            start = time.perf_counter()
            collision_check.CollisionChecker(robot, coal_obstacles([BOX])).fixed_overlaps
            setup = time.perf_counter() - start
            # first pass: the mesh pieces a problem needs are built on first use (once per
            # robot and process); second pass: the same problems again, pieces built
            for label in ("first pass", "again"):
                shares, feasible, largest, named = [], [], 0.0, []
                for k in chosen:
                    kwargs = resolve(problems[k], Path("."))
                    checks.clear()
                    start = time.perf_counter()
                    result = plan(**kwargs, covariance=False)
                    wall = time.perf_counter() - start
                    shares.append(sum(checks) / wall)
                    if problems[k].expected == "feasible":
                        feasible.append(shares[-1])
                    largest = max([largest] + checks)
                    if arm == "jaco" and k in (11, 155):
                        named.append(f"[{k}] plan {wall:.2f} s, checks {sum(checks):.2f} s (largest "
                                     f"{max(checks, default=0.0):.2f} s), success {result.success}")
                print(f"verdict inside plan(), {arm}, {len(chosen)} scene-benchmark problems, {label}: check "
                      f"share of plan time median {100 * np.median(shares):.1f} %, p99 "
                      f"{100 * np.percentile(shares, 99):.1f} % (feasible ones: median "
                      f"{100 * np.median(feasible):.1f} %, p99 {100 * np.percentile(feasible, 99):.1f} %; target "
                      f"<= 20 %); largest single check {largest:.2f} s (target <= 1 s)")
                for line in named:
                    print("  " + line)
            print(f"  robot set-up (geometry, whole-mesh hulls; once per robot and process) {setup:.2f} s")
    finally:
        collision_check.CollisionChecker.check = record


def broad_phase(robot, q: np.ndarray, t: np.ndarray) -> None:
    """10,000 obstacles, 12 near the path, against the 12 alone (the anchor)."""
    rng = np.random.default_rng(1)
    path = robot.frame_positions(q)[:, 2:].reshape(-1, 3)
    near = [Sphere(path[rng.integers(len(path))] + rng.normal(0.0, 0.1, 3), rng.uniform(0.01, 0.03))
            for _ in range(12)]
    centres = rng.uniform(-10.0, 10.0, (10_000 - len(near), 3))
    centres[:, 2] = np.abs(centres[:, 2]) + 2.0
    far = [Box(c, [0.05, 0.05, 0.05]) for c in centres]
    start = time.perf_counter()
    many = CollisionChecker(robot, coal_obstacles(near + far))
    build_s = time.perf_counter() - start
    few = CollisionChecker(robot, coal_obstacles(near))
    reports = []
    many_ms = median_ms(lambda: reports.append(many.check(q, t)), 5, warmup=1)
    few_ms = median_ms(lambda: few.check(q, t), 5, warmup=1)
    print(f"broad phase: 10,000 obstacles (12 near the path) {many_ms:.1f} ms per check, the 12 near ones "
          f"alone {few_ms:.1f} ms (ratio {many_ms / few_ms:.2f}); broad phase "
          f"{1e3 * reports[-1].timings['broad_phase']:.1f} ms; "
          f"building the checker (coal shapes of 10,000 obstacles) {build_s:.2f} s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--problems", type=int, default=12, help="scene-benchmark problems per arm")
    args = parser.parse_args()
    print_environment()
    demos = shared_demonstrations("box_closing")
    if demos is None:
        return
    prior = learn_prior(demos)
    robot = load_robot("jaco")
    scene = Scene([BOX])
    result = plan(prior, robot, scene, start=START)
    plan_ms = median_ms(lambda: plan(prior, robot, scene, start=START), 3, warmup=0)
    free_ms = median_ms(lambda: plan(prior, robot, None, start=START), 5)
    q, t = result.q, result.time
    inside = [plan(prior, robot, scene, start=START).timings for _ in range(5)]
    share = np.median([t["clearance"] / t["total"] for t in inside])
    print(f"plan: T = {len(q)}, {plan_ms:.0f} ms with the box, {free_ms:.0f} ms without; "
          f"verdict clearance {1e3 * result.min_clearance:.1f} mm ({result.collision_geometry}); "
          f"inside plan() the real-geometry check takes a median {100 * share:.1f} % of the plan "
          f"({1e3 * np.median([t['clearance'] for t in inside]):.1f} ms; target <= 20 %)")

    cold = load_robot("jaco")                       # a robot whose convex hulls are not built yet
    start = time.perf_counter()
    cold.collision_model
    load_ms = 1e3 * (time.perf_counter() - start)
    start = time.perf_counter()
    CollisionChecker(cold, coal_obstacles(scene))
    build_ms = 1e3 * (time.perf_counter() - start)
    start = time.perf_counter()
    checker = CollisionChecker(cold, coal_obstacles(scene))
    rebuild_ms = 1e3 * (time.perf_counter() - start)
    print(f"checker: URDF meshes loaded by Pinocchio {load_ms:.0f} ms, convex hulls (coal) {build_ms:.0f} ms "
          f"(once per robot), a checker for new obstacles {rebuild_ms:.2f} ms")

    reports = []
    check_ms = median_ms(lambda: reports.append(checker.check(q, t)), REPEATS, warmup=2)
    report = reports[-1]
    phases = {key: np.median([r.timings[key] for r in reports]) * 1e3 for key in report.timings}
    print(f"check (box): median {check_ms:.1f} ms = {100 * check_ms / plan_ms:.1f} % of the plan "
          f"({100 * check_ms / free_ms:.0f} % of an obstacle-free plan); "
          + ", ".join(f"{k} {v:.1f}" for k, v in phases.items()))
    nearest = report.nearest
    print(f"  {report.num_configurations} configurations ({len(q)} states), coal queries: {report.num_hull} on "
          f"hulls, {report.num_exact} on meshes; min {1e3 * report.min_distance:.2f} mm at {nearest.link} / {nearest.obstacle}, "
          f"index {nearest.index:.2f} (t = {nearest.time:.2f} s); whole motion >= {1e3 * report.lower_bound:.2f} mm; "
          f"collision {report.collision}")
    spheres = CollisionChecker(robot, coal_obstacles(scene), geometry="spheres").check(q, t)
    print(f"  same trajectory on the collision spheres: min {1e3 * spheres.min_distance:.2f} mm "
          f"(meshes - spheres: {1e3 * (report.min_distance - spheres.min_distance):+.2f} mm)")

    crowded = Scene([BOX] + extra_obstacles(result.ee_path))
    many = CollisionChecker(robot, coal_obstacles(crowded))
    crowded_reports = []
    many_ms = median_ms(lambda: crowded_reports.append(many.check(q, t)), 9, warmup=1)
    crowded_report = crowded_reports[-1]
    phases = {key: np.median([r.timings[key] for r in crowded_reports]) * 1e3 for key in crowded_report.timings}
    print(f"check (box + 4 obstacles near the path): median {many_ms:.1f} ms, min "
          f"{1e3 * crowded_report.min_distance:.2f} mm at {crowded_report.nearest.link} / "
          f"{crowded_report.nearest.obstacle}; coal queries: {crowded_report.num_hull} on hulls, "
          f"{crowded_report.num_exact} on meshes; " + ", ".join(f"{k} {v:.1f}" for k, v in phases.items()))
    margin_reports = []
    margin_ms = median_ms(lambda: margin_reports.append(many.check(q, t, margin=0.01)), 9, warmup=1)
    print(f"  the same with margin 0.01: median {margin_ms:.1f} ms, collision {margin_reports[-1].collision}, "
          f"{margin_reports[-1].num_exact} mesh queries, {int(margin_reports[-1].states_in_collision.sum())} "
          "states closer than the margin")

    states = np.linspace(0, len(q) - 1, 10).astype(int)
    coal_ms = median_ms(lambda: checker.reference_distances(q[states]), 3, warmup=0) / len(states)
    print(f"coal's own mesh distance (pin.computeDistances, {len(checker.geometry_names)} link pairs): "
          f"{coal_ms:.1f} ms per state, ~{coal_ms * len(q):.0f} ms for the {len(q)} support states alone")
    broad_phase(robot, q, t)
    verdict_share(args.problems)


if __name__ == "__main__":
    main()
