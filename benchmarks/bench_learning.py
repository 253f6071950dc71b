"""Benchmark of CLAMP prior learning: median wall time of learn_prior.

Cases: box_closing.mat (6 demonstrations, T = 250; skipped with a note when
../shared/datasets is absent) per axis and coupled, and a synthetic set with T = 1000.
Also times the prior's log-likelihood of the demonstrations and sampling 1000 trajectories.

Run: python benchmarks/bench_learning.py [--repeats 21]
"""
from __future__ import annotations

import argparse
import warnings

import numpy as np

from clamp import ClampWarning, learn_prior
from scenes import make_demonstrations
from harness import median_seconds, print_environment, shared_demonstrations



def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=21)
    args = parser.parse_args()
    print_environment()
    warnings.simplefilter("ignore", ClampWarning)   # coupled learning from 6 demos warns

    sets = []
    box_closing = shared_demonstrations("box_closing")
    if box_closing is not None:
        sets.append(("box_closing.mat (M=6, T=250)", box_closing))
    sets.append(("synthetic box_closing (M=6, T=1000)",
                 make_demonstrations("box_closing", num_demos=6, num_points=1000, seed=0)))

    print(f"median of {args.repeats} runs")
    for name, demos in sets:
        per_axis = median_seconds(lambda: learn_prior(demos), args.repeats)
        coupled = median_seconds(lambda: learn_prior(demos, coupled=True), args.repeats)
        prior = learn_prior(demos)
        states = demos.states
        loglik = median_seconds(lambda: prior.log_likelihood(states), args.repeats)
        rng = np.random.default_rng(0)
        sample = median_seconds(lambda: prior.sample(1000, rng), max(3, args.repeats // 4))
        print(f"{name}:")
        print(f"  learn_prior per axis     {1e3 * per_axis:8.2f} ms")
        print(f"  learn_prior coupled      {1e3 * coupled:8.2f} ms   (coupled / per axis = "
              f"{coupled / per_axis:.2f})")
        print(f"  log_likelihood of M demos {1e3 * loglik:7.2f} ms")
        print(f"  sample 1000 trajectories {1e3 * sample:8.2f} ms")


if __name__ == "__main__":
    main()
