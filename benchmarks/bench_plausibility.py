"""Benchmark of clamp.prior.plausibility: median wall time of one plausibility score.

Priors learned from the synthetic box-closing skill (6 demonstrations) at T = 250 and
T = 2000 (same duration), plus box_closing.mat (T = 250) when ../shared/datasets is present.
"cold" is the first score of a prior (it builds and caches the floored chain: Cholesky and
inverse of every Q_i + floor); "warm" every later score of the same prior, which is what the
planner pays per plan. Also: start + goal + 2 vias, a batch of 100 paths, and
conditional_mean (not on the scoring path).

Run: python benchmarks/bench_plausibility.py [--repeats 21]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from clamp import learn_prior
from clamp.prior.plausibility import conditional_mean, floored_prior, plausibility
from harness import median_seconds, print_environment, shared_demonstrations
from scenes import make_demonstrations


def cold_seconds(demos, x, repeats: int) -> float:
    """Median time of the first score of a freshly learned (uncached) prior."""
    times = []
    for _ in range(repeats):
        prior = learn_prior(demos)
        start = time.perf_counter()
        plausibility(prior, x)
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=21)
    args = parser.parse_args()
    print_environment()
    sets = []
    box_closing = shared_demonstrations("box_closing")
    if box_closing is not None:
        sets.append(("box_closing.mat (M=6, T=250)", box_closing))
    for T in (250, 2000):
        sets.append((f"synthetic box_closing (M=6, T={T})",
                     make_demonstrations("box_closing", num_demos=6, num_points=T,
                                         dt=0.16 * 249 / (T - 1), seed=0)))
    print(f"median of {args.repeats} runs")
    for name, demos in sets:
        prior = learn_prior(demos)
        T = prior.T
        x = demos.states[0]
        goal, vias = x[-1, :3], [(T // 3, x[T // 3, :3]), (2 * T // 3, x[2 * T // 3, :3])]
        batch = floored_prior(prior).sample(100, 0)
        cold = cold_seconds(demos, x, max(3, args.repeats // 3))
        warm = median_seconds(lambda: plausibility(prior, x), args.repeats)
        full = median_seconds(lambda: plausibility(prior, x, goal=goal, via=vias), args.repeats)
        many = median_seconds(lambda: plausibility(prior, batch), max(3, args.repeats // 3))
        mean = median_seconds(lambda: conditional_mean(prior, x[0, :3], goal),
                              max(3, args.repeats // 3))
        print(f"{name}:")
        print(f"  one score, start only, cold  {1e3 * cold:8.2f} ms")
        print(f"  one score, start only, warm  {1e3 * warm:8.2f} ms")
        print(f"  one score, start+goal+2 vias {1e3 * full:8.2f} ms")
        print(f"  100 paths in one call        {1e3 * many:8.2f} ms")
        print(f"  conditional_mean start+goal  {1e3 * mean:8.2f} ms")


if __name__ == "__main__":
    main()
