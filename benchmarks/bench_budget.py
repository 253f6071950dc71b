"""The search's budget (issue 36): a request the scene does not allow, cut by a wall-clock
deadline, returns near it; under the counted default, the same request gives the same plan, bit
for bit, at two loads.

The request: pick_place (6 synthetic demonstrations, seed 0, 250 states) on the Jaco from its
mean start, a 12 cm cube over the skill's mean end (no plan completes it). Prints, per
deadline, the whole call's wall time over the deadline (median of ``--repeats``); then the
counted default planned once as it is and once while ``--burners`` busy processes load the
machine: whether the two plans are identical and their times.

    python benchmarks/bench_budget.py [--deadlines 1 2 4] [--repeats 3] [--burners 2]
"""
from __future__ import annotations

import argparse
import multiprocessing
import sys
import time

import numpy as np

from harness import print_environment


def _burn(stop: float) -> None:
    while time.perf_counter() < stop:
        sum(i * i for i in range(10_000))


def request():
    from clamp import learn_prior
    from robots import load_robot
    from scenes import Box, Scene, make_demonstrations
    prior = learn_prior(make_demonstrations("pick_place", num_demos=6, num_points=250, seed=0))
    mean = np.asarray(prior.mean)[:, :3]
    return prior, load_robot("jaco"), Scene([Box(mean[-1], [0.12] * 3)]), mean[0]


def main(argv: list[str] | None = None) -> int:
    from clamp import plan
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--deadlines", type=float, nargs="*", default=[1.0, 2.0, 4.0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--burners", type=int, default=2)
    args = parser.parse_args(argv)
    print_environment()
    prior, robot, scene, start = request()
    plan(prior, robot, None, start, covariance=False)                # warm-up
    for deadline in args.deadlines:
        walls, cut = [], []
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            result = plan(prior, robot, scene, start, covariance=False, budget=None,
                          deadline=deadline)
            walls.append(time.perf_counter() - t0)
            cut.append(result.search["budget_ended"])
        print(f"deadline {deadline:.1f} s: wall median {np.median(walls):.2f} s = "
              f"{np.median(walls) / deadline:.2f}x the deadline (max {max(walls):.2f} s); "
              f"cut by it {sum(cut)} / {len(cut)}; success {result.success}")
    t0 = time.perf_counter()
    quiet = plan(prior, robot, scene, start, covariance=False)
    quiet_s = time.perf_counter() - t0
    stop = time.perf_counter() + 10 * quiet_s + 30
    burners = [multiprocessing.Process(target=_burn, args=(stop,)) for _ in range(args.burners)]
    for b in burners:
        b.start()
    t0 = time.perf_counter()
    loaded = plan(prior, robot, scene, start, covariance=False)
    loaded_s = time.perf_counter() - t0
    for b in burners:
        b.terminate()
    same = np.array_equal(quiet.q, loaded.q) and quiet.search == loaded.search
    print(f"counted budget {quiet.search['limit']:.0f} (work {quiet.search['work']}): plans "
          f"{'bit-identical' if same else 'DIFFERENT'} at two loads ({quiet_s:.2f} s, and "
          f"{loaded_s:.2f} s with {args.burners} busy processes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
