"""Memory soak: many plans in one process must not grow its resident memory.

Plans box_closing (../shared/datasets, else the synthetic skill) on the Jaco ``--plans`` times,
each with one new random box near the demonstrated path (a scene new to the planner every
time), and prints the resident set size (RSS) after plan 20 and after the last plan, and the
difference (target: at most 20 MB after 500 plans).

    python benchmarks/soak_clamp.py [--plans 500]
"""
from __future__ import annotations

import argparse
import gc
import time

import numpy as np

from harness import print_environment, shared_demonstrations


def rss_mb() -> float:
    """Resident set size of this process in MB (Linux /proc)."""
    with open("/proc/self/statm") as f:
        pages = int(f.read().split()[1])
    import os
    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plans", type=int, default=500)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    print_environment()
    from clamp import learn_prior, plan
    from robots import load_robot
    from scenes import Box, Scene, make_demonstrations

    demos = shared_demonstrations("box_closing") or make_demonstrations("box_closing")
    prior = learn_prior(demos)
    robot = load_robot("jaco")
    start = demos.positions[:, 0].mean(axis=0)
    path = np.asarray(prior.mean)[:, :3]
    rng = np.random.default_rng(args.seed)
    marks: dict[int, float] = {}
    successes = 0
    t0 = time.perf_counter()
    for k in range(1, args.plans + 1):
        centre = path[rng.integers(len(path) // 4, len(path))] + rng.normal(scale=0.05, size=3)
        scene = Scene([Box(centre, rng.uniform(0.03, 0.08, size=3))])
        result = plan(prior, robot, scene, start)
        successes += result.success
        del result, scene
        if k in (1, 20, 100, 200, args.plans) or k % 100 == 0:
            gc.collect()
            marks[k] = rss_mb()
            print(f"after plan {k:4d}: RSS {marks[k]:7.1f} MB  ({time.perf_counter() - t0:6.1f} s)",
                  flush=True)
    last = max(marks)
    print(f"\nRSS after plan {last} minus after plan 20: {marks[last] - marks[20]:+.1f} MB "
          f"(target <= 20 MB); {successes}/{args.plans} plans succeeded")


if __name__ == "__main__":
    main()
