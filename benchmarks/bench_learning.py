"""Benchmark of CLAMP prior learning: median wall time of learn_prior.

Cases: box_closing.mat (6 demonstrations, T = 250; skipped with a note when
../shared/datasets is absent) per axis and coupled, and a synthetic set with T = 1000.
Also times the prior's log-likelihood of the demonstrations and sampling 1000 trajectories,
and the incremental learner (method="incremental"): one ``prior.update`` with one new
demonstration at T = 250 (target <= 5 ms), split into the conjugate posterior update and the
new prior's construction (marginals, whitening: what every learned prior costs), anchored on
learning the batch prior from scratch.

Run: python benchmarks/bench_learning.py [--repeats 21]
"""
from __future__ import annotations

import argparse
import types
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
    incremental_update(args.repeats)


def incremental_update(repeats: int) -> None:
    """One prior.update with one new demonstration at T = 250, against batch relearning."""
    demos = make_demonstrations("box_closing", num_demos=7, num_points=250, seed=0)
    prior = learn_prior(types.SimpleNamespace(positions=demos.positions[:6],
                                              velocities=demos.velocities[:6], time=demos.time),
                        method="incremental")
    new = types.SimpleNamespace(positions=demos.positions[6:], velocities=demos.velocities[6:],
                                time=demos.time)
    states = demos.states[6:]
    update = median_seconds(lambda: prior.update(new), repeats)
    posterior = median_seconds(lambda: prior.posterior.update(states), repeats)
    relearn = median_seconds(lambda: learn_prior(demos, method="incremental"), repeats)
    batch = median_seconds(lambda: learn_prior(demos), repeats)
    print("incremental learning, synthetic box_closing, T = 250, 6 + 1 demonstrations:")
    print(f"  prior.update(1 demo)        {1e3 * update:8.2f} ms   (target <= 5 ms)")
    print(f"    of which posterior update {1e3 * posterior:8.2f} ms")
    print(f"  relearn 7 demos incremental {1e3 * relearn:8.2f} ms")
    print(f"  anchor: batch learn_prior   {1e3 * batch:8.2f} ms   (update / batch = "
          f"{update / batch:.2f})")


if __name__ == "__main__":
    main()
