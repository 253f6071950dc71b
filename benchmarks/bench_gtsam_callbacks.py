"""Why GTSAM's own optimizers are slow on the planner's graph: the cost of one Python
CustomFactor call inside a GTSAM optimizer grows with the size of the Values.

Inside ``optimizer.iterate()`` GTSAM hands every ``gtsam.CustomFactor`` the optimizer's own
``const Values&``; that C++ object is not owned by Python, so the binding copies the whole
Values for every call: a call costs O(number of variables) and one iteration
O(factors x variables). Called from Python (``graph.linearize(values)`` with a Values Python
owns) the same factors cost a few microseconds each. The table prints, for a trivial unary
CustomFactor on every variable, microseconds per factor call both ways; the second table the
planner's own graph (box_closing, Jaco, empty scene): ``graph.linearize`` from Python vs one
``iterate()`` of GTSAM's Gauss-Newton (one linearization + one solve + one error) and the
solve alone.

    python benchmarks/bench_gtsam_callbacks.py
"""
from __future__ import annotations

import time
import warnings

import gtsam
import numpy as np

from harness import median_seconds, print_environment, shared_demonstrations


def _identity_error(this, values, H):
    if H is not None:
        H[0] = np.eye(2)
    return np.zeros(2)


def _chain(size: int) -> tuple[gtsam.NonlinearFactorGraph, gtsam.Values]:
    graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
    for i in range(size):
        values.insert(i, np.zeros(2))
        graph.add(gtsam.CustomFactor(gtsam.noiseModel.Unit.Create(2), [i], _identity_error))
    return graph, values


def _iterate_seconds(graph, values, repeats: int = 3) -> float:
    params = gtsam.GaussNewtonParams()
    params.setLinearSolverType("SEQUENTIAL_QR")

    def one():
        gtsam.GaussNewtonOptimizer(graph, values, params).iterate()
    return median_seconds(one, repeats)


def main() -> None:
    print_environment()
    warnings.simplefilter("ignore")
    print("\ntrivial unary CustomFactor per variable: us per factor call")
    print(f"{'variables':>9} {'from Python':>12} {'inside iterate()':>17} {'ratio':>6}")
    for size in (10, 100, 250, 1000):
        graph, values = _chain(size)
        direct = median_seconds(lambda: graph.linearize(values), 5) / size
        inside = _iterate_seconds(graph, values) / size
        print(f"{size:>9d} {1e6 * direct:>12.1f} {1e6 * inside:>17.1f} {inside / direct:>6.1f}")

    from clamp import build, learn_prior
    from robots import load_robot
    from scenes import make_demonstrations

    demos = shared_demonstrations("box_closing") or make_demonstrations("box_closing")
    problem = build(learn_prior(demos), load_robot("jaco"), None,
                    demos.positions[:, 0].mean(axis=0))
    graph, values = problem.graph(), problem.values()
    custom = sum(isinstance(graph.at(i), gtsam.CustomFactor) for i in range(graph.size()))
    print(f"\nplanner graph (box_closing, Jaco, T={problem.num_states}): {graph.size()} factors, "
          f"{custom} CustomFactors")
    linearize = median_seconds(lambda: graph.linearize(values), 5)
    gaussian = graph.linearize(values)
    ordering = gtsam.Ordering()
    for key in problem.keys:
        ordering.push_back(key)
    solve = median_seconds(lambda: gaussian.eliminateSequential(ordering, gtsam.EliminateQR), 5)
    iterate = _iterate_seconds(graph, values)
    start = time.perf_counter()
    graph.error(values)
    error = time.perf_counter() - start
    print(f"graph.linearize from Python {1e3 * linearize:7.1f} ms; graph.error {1e3 * error:5.1f} ms; "
          f"sequential QR elimination {1e3 * solve:5.1f} ms")
    print(f"Gauss-Newton iterate()      {1e3 * iterate:7.1f} ms "
          f"(x{iterate / (linearize + solve + error):.1f} the sum of its parts called from Python)")


if __name__ == "__main__":
    main()
