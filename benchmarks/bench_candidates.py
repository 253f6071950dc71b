"""What solving K candidate starts together would cost against K sequential solves (issue 36,
item 4: cuRobo's many seeds at once, on a CPU).

A batch of K candidates of T states is K independent chains: its Gauss-Newton system has the
banded structure and the flops of one chain of K T states, and its kinematics are K T
configurations in one call. So each stage is timed at T (one candidate) and at K T (the batch),
with the library's own kernels, on the Jaco and box_closing (synthetic, T = 250):

- ``kinematics``: the end effector's pose and Jacobians and the collision spheres' centres and
  Jacobians (``Robot.ee_kinematics``, ``Robot.sphere_centres``) of K T configurations;
- ``banded solve``: one damped banded Cholesky solve (``clamp.optim.solver.DampedBandSolver``)
  of a block-tridiagonal system of K T blocks of 2n x 2n;
- ``whole plan``: a free ``clamp.plan()`` of the skill resampled to K T states, per LM
  iteration (a bound: it also pays the prior's learning, which a batch would not).

Prints per stage and K: the batch's median CPU time (a loaded machine keeps it), K sequential times, and their ratio (below
1: the batch is cheaper). The search's candidates are only worth batching when a request needs
many of them: a plan that passes on its first candidate pays the batch for nothing.

    python benchmarks/bench_candidates.py [--repeats 5] [--ks 1 2 4 8]
"""
from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from harness import median_seconds, print_environment, print_machine_reference

STATES = 250


def kinematics_stage(robot, rng: np.random.Generator):
    """A function of the number of states N timing the kinematics of N configurations."""
    def run(N: int, repeats: int) -> float:
        q = np.stack([robot.random_configuration(rng) for _ in range(N)])
        qdot = 0.1 * rng.standard_normal(q.shape)
        return median_seconds(lambda: (robot.ee_kinematics(q, qdot), robot.sphere_centres(q, jacobians=True)),
                              repeats, clock=time.process_time)
    return run


def banded_stage(n: int, rng: np.random.Generator):
    """A function of N timing one damped banded solve of N blocks of 2n x 2n."""
    from clamp.optim.banded import band_layout
    from clamp.optim.solver import DampedBandSolver
    d = 2 * n

    def run(N: int, repeats: int) -> float:
        J = rng.standard_normal((N, d, d))
        D = J @ np.swapaxes(J, 1, 2) + 4 * d * np.eye(d)           # diagonally dominant: positive definite
        E = 0.5 * rng.standard_normal((N - 1, d, d))
        layout = band_layout(N, d)
        band, g = layout.band(D, E), rng.standard_normal(N * d)
        return median_seconds(lambda: DampedBandSolver(band, g, layout.rows).solve(1e-3), repeats, clock=time.process_time)
    return run


def plan_stage(robot):
    """A function of N timing a free plan of box_closing at N states, per LM iteration."""
    from clamp import learn_prior, plan
    from scenes import make_demonstrations
    demos = make_demonstrations("box_closing")
    start = demos.positions[:, 0].mean(axis=0)

    def run(N: int, repeats: int) -> float:
        prior = learn_prior(demos.resample(N))
        result = plan(prior, robot, None, start)
        return median_seconds(lambda: plan(prior, robot, None, start), repeats,
                              clock=time.process_time) / max(result.iterations, 1)
    return run


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=5, help="timed calls per measurement (median)")
    parser.add_argument("--ks", type=int, nargs="+", default=[1, 2, 4, 8], help="batch sizes K")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    from robots import load_robot
    print_environment()
    print_machine_reference()
    jaco, rng = load_robot("jaco"), np.random.default_rng(0)
    stages = {"kinematics": kinematics_stage(jaco, rng), "banded solve": banded_stage(jaco.n, rng),
              "whole plan / iteration": plan_stage(jaco)}
    print(f"\nJaco, T = {STATES} states a candidate; CPU times [ms], medians of {args.repeats}")
    print(f"{'stage':24s} {'K':>3s} {'batch ms':>10s} {'K x one ms':>11s} {'batch / sequential':>19s}")
    for name, stage in stages.items():
        one = stage(STATES, args.repeats)
        for K in args.ks:
            batch = one if K == 1 else stage(K * STATES, args.repeats)
            print(f"{name:24s} {K:3d} {1e3 * batch:10.2f} {1e3 * K * one:11.2f} {batch / (K * one):19.2f}")
    print(f"\nmeasured at {time.strftime('%H:%M:%S')}")


if __name__ == "__main__":
    main()
