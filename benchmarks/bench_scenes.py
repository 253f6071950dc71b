"""Scene benchmark: CLAMP in new scenes on the Jaco and the Sawyer, at the default settings.

Per arm, ``--count`` seeded problems of :func:`clamp.batch.problem_sets.scene_benchmark` (4 skills,
start near the demonstrations' start, goal at the skill's end, 1-3 random boxes / spheres /
cylinders near the skill's path; 20 % made impossible: an obstacle over the start or the
goal), planned with ``clamp.batch.runner.plan_many`` and judged independently of the planner's
verdict: every plan the planner calls a success is checked on the robot's URDF collision
geometry (``robots.collision_check.CollisionChecker`` with ``scenes.coal_shapes``, at and
between the support states, margin 0, 5 mm motion steps); a collision there is a false
success. Prints, per arm: success on the feasible problems (planner's verdict, and of those
collision-free on the real geometry), false successes, how many impossible problems failed
with a reason, failure reasons, median / p95 plan time; and the same problems without their
obstacles (the empty-scene baseline) with the time ratio to it.

    python benchmarks/bench_scenes.py [--count 200] [--quick] [--robots jaco sawyer]
                                      [--workers N] [--problems-out DIR]
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from harness import print_environment


def judge(record: dict, problem, robot, checkers: dict) -> float | None:
    """Least distance [m] of a successful plan to its scene on the URDF geometry (None when
    the plan did not succeed or the scene is empty)."""
    from robots.collision_check import CollisionChecker
    from scenes import Scene
    from scenes.coal_shapes import coal_obstacles
    if not (record["status"] == "done" and record["success"]) or problem.scene is None:
        return None
    if problem.hash not in checkers:
        scene = Scene.from_dict(problem.scene_data())
        checkers[problem.hash] = CollisionChecker(robot, coal_obstacles(scene))
    points = record["trajectory"]["points"]
    q = np.array([p["positions"] for p in points])
    t = np.array([p["time_from_start"] for p in points])
    return checkers[problem.hash].check(q, t, margin=0.0, max_motion=0.005).min_distance


def run_arm(name: str, count: int, seed: int, executor, out: Path | None) -> None:
    from clamp.batch.runner import load_robot, plan_many
    from clamp.batch.report import summarize, summary_table
    from clamp.batch.problem_sets import scene_benchmark
    from clamp.batch.problems import write_problems
    robot = load_robot({"name": name}, Path("."))
    t0 = time.perf_counter()
    problems = scene_benchmark(count, name, seed)
    print(f"\n=== {name}: {len(problems)} problems (seed {seed}), generated in "
          f"{time.perf_counter() - t0:.1f} s")
    if out is not None:
        write_problems(problems, out / f"scenes_{name}.jsonl", overwrite=True)
    by_hash = {p.hash: p for p in problems}
    records = list(plan_many(problems, executor))
    checkers: dict = {}
    distance = {r["id"]: judge(r, by_hash[r["hash"]], robot, checkers) for r in records}
    feasible = [r for r in records if r["expected"] == "feasible"]
    impossible = [r for r in records if r["expected"] == "impossible"]
    solved = [r for r in feasible if r["status"] == "done" and r["success"]]
    false = [r for r in records if distance[r["id"]] is not None and distance[r["id"]] < 0.0]
    clean = [r for r in solved if distance[r["id"]] >= 0.0]
    failed_reason = [r for r in impossible if not r["success"] and (r["reasons"] or r["error"])]
    summary = summarize(records)
    print(summary_table(summary))
    print(f"feasible: planner success {len(solved)} / {len(feasible)} "
          f"({100 * len(solved) / max(1, len(feasible)):.1f} %), collision-free on the URDF "
          f"geometry {len(clean)} / {len(feasible)} ({100 * len(clean) / max(1, len(feasible)):.1f} %)")
    reasons = summarize(feasible)["reasons"]
    print("failure reasons on the feasible problems: "
          + "; ".join(f"{key} {n}" for key, n in reasons.items()))
    print(f"false successes (planner success, URDF geometry in collision): {len(false)} "
          f"({sum(r['expected'] == 'feasible' for r in false)} feasible, "
          f"{sum(r['expected'] == 'impossible' for r in false)} impossible)")
    for r in false[:5]:
        print(f"  {r['id']}: URDF distance {1e3 * distance[r['id']]:.1f} mm, "
              f"sphere clearance {1e3 * (r['verdict']['min_clearance_m'] or np.inf):.1f} mm")
    print(f"impossible problems failing with a reason: {len(failed_reason)} / {len(impossible)}")
    passed = [r for r in impossible if r["success"]]
    if passed:
        kinds = ", ".join(f"{kind} covered {sum(r['meta']['impossible'] == kind for r in passed)}"
                          for kind in ("start", "goal"))
        print(f"  impossible problems planned as a success: {len(passed)} ({kinds}); their least "
              f"URDF distance {1e3 * min(distance[r['id']] for r in passed):.1f} mm")
    empty = [p.replace(scene=None) for p in problems]
    base = summarize(list(plan_many(empty, executor, trajectories="none")))
    print(f"empty-scene baseline: success {base['success']} / {base['problems']}, plan time "
          f"median {1e3 * base['median_s']:.1f} ms, p95 {1e3 * base['p95_s']:.1f} ms")
    print(f"median plan time with obstacles / empty: {summary['median_s'] / base['median_s']:.2f}x "
          f"(target <= 3)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=200, help="problems per arm (default 200)")
    parser.add_argument("--quick", action="store_true", help="40 problems per arm")
    parser.add_argument("--robots", nargs="+", default=["jaco", "sawyer"])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=None,
                        help="local worker processes (default: this process)")
    parser.add_argument("--problems-out", type=Path, default=None,
                        help="folder to write the problem files to (scenes_<robot>.jsonl)")
    args = parser.parse_args()
    print_environment()
    from clamp.batch.runner import LocalPool
    count = 40 if args.quick else args.count
    pool = LocalPool(args.workers) if args.workers else None
    try:
        for name in args.robots:
            run_arm(name, count, args.seed, pool, args.problems_out)
    finally:
        if pool is not None:
            pool.shutdown()


if __name__ == "__main__":
    main()
