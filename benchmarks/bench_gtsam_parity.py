"""Do GTSAM's own optimizers reach the fast solver's optimum on box_closing, and how fast?

Problem: box_closing's learned prior, Jaco, REFERENCE_START, empty scene and REFERENCE_BOX (as
in bench_clamp.py). Reference optimum: the fast solver run to convergence (relative and
absolute tolerance 1e-10, patience 10). Each GTSAM optimizer of :mod:`clamp.optim.optimizers` (its
settings, tolerances 1e-12) runs from the problem's initial trajectory, as
``optimize(problem, PlannerConfig(optimizer=...))`` does (the optimizer's Values held so
linearizations do not copy them), until it stops or ``--budget`` seconds pass. Table 1: the
first (iteration, seconds) at which the graph error is within 1e-2 / 1e-4 / 1e-6 relative of
the reference and the end-effector path within 1 mm / 0.1 mm of it; where it ended.

Table 2: where one Levenberg-Marquardt iteration's time goes (30 iterations from the initial
trajectory): ms per iteration with and without holding the optimizer's Values, the factor calls
per iteration, the Python time inside the adapters, the rest (pybind11's Values copies and
GTSAM's C++), and a pure C++ iteration (the same linearized graph as LinearContainerFactors:
GTSAM's linear algebra alone, a floor for any Python factor).

Table 0 (issue 27): do GTSAM's optimizers, as the planner configures them
(:func:`clamp.optim.optimizers.gtsam_params`, printed), reach the fast solver's *plan*: the
end-effector path of ``clamp.plan`` with the default config, max distance over the states, on
box_closing (synthetic ``make_demonstrations("box_closing", num_demos=6, seed=0)`` and the
recorded box_closing.mat when present), Jaco, REFERENCE_START, the empty scene and the README
box. With the box the plan comes out of a constrained solve (soft start, shifted hinges, the
posture tie): GTSAM runs on ``result.problem.graph()`` (the final problem) and on the
as-built graph (``clamp.build``), each from the problem's own initial values
(``problem.values()``: what the fast solver started from) and from the configured
initialisation (the prior mean's path through IK, ``clamp.build(..., scene=None).initial``);
distance [mm], seconds, iterations, error against the plan's on the same graph.

    python benchmarks/bench_gtsam_parity.py [--budget 5] [--only box] [--tables 0,1,2]
"""
from __future__ import annotations

import argparse
import time
import warnings

import gtsam
import numpy as np

from bench_clamp import REFERENCE_BOX, REFERENCE_START
from harness import median_seconds, print_environment, shared_demonstrations
from clamp.optim.stopping import StoppingRule

#: the fast solver run to its optimum (the tolerances far below any plan's difference)
TIGHT = StoppingRule(relative_tol=1e-10, absolute_tol=1e-10, patience=10)

MILESTONES = (("rel 1e-2", "rel", 1e-2), ("rel 1e-4", "rel", 1e-4), ("rel 1e-6", "rel", 1e-6),
              ("1 mm", "gap", 1.0), ("0.1 mm", "gap", 0.1))


def run_to_budget(problem, config, reference, robot, budget: float) -> dict:
    """Run GTSAM's optimizer of ``config`` as clamp.optim.optimizers.optimize does; milestones."""
    from clamp.graph.keys import values_to_states
    from clamp.optim.optimizers import _CurrentValues, _gtsam_optimizer

    best = problem.graph().error(problem.values(reference))
    ref_ee = robot.fk(reference[:, :robot.n])
    current, first, state = _CurrentValues(), {}, {"overhead": 0.0, "last": (0, np.nan)}
    start = time.perf_counter()

    def hook(iteration: int, before: float, after: float) -> None:
        current.renew()
        now = time.perf_counter()
        clock = now - start - state["overhead"]
        theta = values_to_states(current.values, problem.keys)
        gap = 1e3 * np.max(np.linalg.norm(robot.fk(theta[:, :robot.n]) - ref_ee, axis=1))
        measured = {"rel": after / best - 1, "gap": gap}
        for label, kind, bound in MILESTONES:
            if label not in first and measured[kind] <= bound:
                first[label] = (iteration, clock)
        state["last"] = (iteration, after, gap, clock)
        state["overhead"] += time.perf_counter() - now
        if clock > budget:
            raise RuntimeError("budget")

    optimizer = _gtsam_optimizer(problem, config, hook)
    current.hold(optimizer)
    try:
        optimizer.optimize()
        stop = "converged"
    except RuntimeError as exc:
        stop = "budget" if "budget" in str(exc) else f"error: {exc}"
    finally:
        current.release()
    iteration, error, gap, clock = state["last"]
    return {"first": first, "iterations": iteration, "error": error, "rel": error / best - 1,
            "gap": gap, "seconds": clock, "stop": stop, "best": best}


def gtsam_settings(config) -> str:
    """The GTSAM parameters the planner sets for ``config``, as a GTSAM user would read them."""
    from clamp.optim.optimizers import gtsam_params

    params, _ = gtsam_params(config)
    words = [f"linear solver {params.getLinearSolverType()}",
             f"ordering {params.getOrderingType()}",
             f"maxIterations {params.getMaxIterations()}",
             f"relativeErrorTol {params.getRelativeErrorTol():g}",
             f"absoluteErrorTol {params.getAbsoluteErrorTol():g}"]
    if isinstance(params, gtsam.LevenbergMarquardtParams):
        words += [f"lambdaInitial {params.getlambdaInitial():g}",
                  f"lambdaUpperBound {params.getlambdaUpperBound():g}",
                  f"lambdaLowerBound {params.getlambdaLowerBound():g}",
                  f"useFixedLambdaFactor {params.getUseFixedLambdaFactor()}",
                  f"diagonalDamping {params.getDiagonalDamping()}"]
    elif isinstance(params, gtsam.DoglegParams):
        words += [f"deltaInitial {params.getDeltaInitial():g}"]
    return ", ".join(words)


def parity_table(budget: float, only: str | None, optimizers: list[str]) -> None:
    """Table 0 (module docstring)."""
    from clamp import PlannerConfig, build, learn_prior, plan
    from robots import load_robot
    from scenes import Box, Scene, make_demonstrations

    robot = load_robot("jaco")
    priors = {"synthetic": lambda: learn_prior(make_demonstrations("box_closing", num_demos=6,
                                                                   seed=0))}
    recorded = shared_demonstrations("box_closing")
    if recorded is not None:
        priors["recorded"] = lambda: learn_prior(recorded)
    scenes = {"empty": None, "box": Scene([Box.from_reference(REFERENCE_BOX)])}
    print(f"\nTable 0: GTSAM's optimizers against the fast plan (budget {budget:g} s)")
    for name in optimizers:
        print(f"  {name}: {gtsam_settings(PlannerConfig().with_(optimizer=name))}")
    print(f"{'data':<10} {'scene':<6} {'graph':<9} {'start':<12} {'optimizer':<13} "
          f"{'start mm':>8} {'mm':>8} {'s':>6} {'iters':>5} {'stop':>9} {'error':>10} "
          f"{'plan error':>10}")
    for data, make_prior in priors.items():
        prior = make_prior()
        configured = build(prior, robot, None, REFERENCE_START).initial
        for label, scene in scenes.items():
            if only and label != only:
                continue
            t0 = time.perf_counter()
            result = plan(prior, robot, scene, REFERENCE_START, covariance=False)
            seconds = time.perf_counter() - t0
            theta = np.hstack([result.q, result.qdot])
            print(f"{data} {label}: fast plan {seconds:.2f} s, {result.iterations} iterations, "
                  f"success {result.success}, solves "
                  f"{[(a['candidate'], a['round']) for a in result.attempts]}")
            graphs = {"final": result.problem,
                      "as-built": build(prior, robot, scene, REFERENCE_START)}
            for graph_label, problem in graphs.items():
                if label == "empty" and graph_label == "as-built":
                    continue         # the same problem without obstacles
                starts = {"own values": problem,
                          "configured": problem.with_families(problem.families, configured)}
                for start_label, start in starts.items():
                    for name in optimizers:
                        config = PlannerConfig().with_(optimizer=name)
                        r = run_to_budget(start, config, theta, robot, budget)
                        begin = 1e3 * np.max(np.linalg.norm(
                            robot.fk(start.initial[:, :robot.n]) - result.ee_path, axis=1))
                        print(f"{data:<10} {label:<6} {graph_label:<9} {start_label:<12} "
                              f"{name:<13} {begin:>8.1f} {r['gap']:>8.3f} {r['seconds']:>6.2f} "
                              f"{r['iterations']:>5d} {r['stop']:>9} {r['error']:>10.6g} "
                              f"{r['best']:>10.6g}", flush=True)


def cost_breakdown(problem, hold: bool, iterations: int = 30) -> dict:
    """ms per LM iteration, factor calls and Python time in the adapters per iteration."""
    from clamp import PlannerConfig
    from clamp.graph import gtsam_adapter
    from clamp.optim.optimizers import _CurrentValues, _gtsam_optimizer

    stats = {"linearize": 0, "error": 0, "python": 0.0}
    original = gtsam_adapter._error

    def timed(*args):
        t0 = time.perf_counter()
        try:
            return original(*args)
        finally:
            stats["python"] += time.perf_counter() - t0
            stats["linearize" if args[-1] is not None else "error"] += 1

    gtsam_adapter._error = timed
    try:
        config = PlannerConfig().with_(optimizer="gtsam", max_iterations=iterations,
                                       stopping=StoppingRule(relative_tol=0.0, absolute_tol=0.0))
        current = _CurrentValues()
        optimizer = _gtsam_optimizer(problem, config,
                                     (lambda *_: current.renew()) if hold else None)
        stats.update(linearize=0, error=0, python=0.0)
        if hold:
            current.hold(optimizer)
        t0 = time.perf_counter()
        optimizer.optimize()
        seconds = time.perf_counter() - t0
        current.release()
    finally:
        gtsam_adapter._error = original
    n = max(int(optimizer.iterations()), 1)
    return {"ms": 1e3 * seconds / n, "linearize": stats["linearize"] / n,
            "error": stats["error"] / n, "python": 1e3 * stats["python"] / n,
            "values": optimizer.values()}


def pure_cpp_iteration(problem, values) -> float:
    """ms of one GTSAM LM iteration on the graph linearized at ``values`` (C++ factors only)."""
    from clamp import PlannerConfig
    from clamp.optim.optimizers import gtsam_params

    linear = problem.graph().linearize(values)
    graph = gtsam.NonlinearFactorGraph()
    for i in range(linear.size()):
        graph.add(gtsam.LinearContainerFactor(linear.at(i), values))
    params, _ = gtsam_params(PlannerConfig(optimizer="gtsam"))
    params.setMaxIterations(1)

    def one():
        gtsam.LevenbergMarquardtOptimizer(graph, values, params).iterate()
    return 1e3 * median_seconds(one, 5)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budget", type=float, default=5.0, help="seconds per GTSAM run")
    parser.add_argument("--only", choices=("empty", "box"), default=None)
    parser.add_argument("--optimizers", default="gtsam,gtsam_dogleg")
    parser.add_argument("--tables", default="0,1,2", help="which tables to print")
    args = parser.parse_args()
    print_environment()
    warnings.simplefilter("ignore")
    tables = set(args.tables.split(","))
    if "0" in tables:
        parity_table(args.budget, args.only, args.optimizers.split(","))
    if not tables & {"1", "2"}:
        return
    from clamp import PlannerConfig, build, learn_prior, optimize
    from robots import load_robot
    from scenes import Box, Scene

    demos = shared_demonstrations("box_closing")
    if demos is None:
        return
    prior, robot = learn_prior(demos), load_robot("jaco")
    tight = PlannerConfig().with_(stopping=TIGHT, max_iterations=5000)
    scenes = {"empty": lambda: None, "box": lambda: Scene([Box.from_reference(REFERENCE_BOX)])}
    problems = {}
    print(f"\nTable 1: GTSAM optimizers against the fast optimum (budget {args.budget:g} s; "
          "milestones: first iteration / seconds)")
    print(f"{'case':<20} " + " ".join(f"{m[0]:>13}" for m in MILESTONES)
          + f" {'stop':>9} {'iters':>6} {'s':>6} {'ms/it':>6} {'rel error':>10} {'EE mm':>8}")
    for label, scene in scenes.items():
        if args.only and label != args.only:
            continue
        problem = problems[label] = build(prior, robot, scene(), REFERENCE_START, config=tight)
        t0 = time.perf_counter()
        fast = optimize(problem, tight)
        fast_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        default = optimize(problem, PlannerConfig())
        default_s = time.perf_counter() - t0
        best = problem.graph().error(problem.values(fast.theta))
        gap = 1e3 * np.max(np.linalg.norm(robot.fk(default.theta[:, :robot.n])
                                          - robot.fk(fast.theta[:, :robot.n]), axis=1))
        print(f"{label}: fast optimum {best:.10g} ({fast.iterations} iterations, {fast_s:.2f} s); "
              f"fast with default tolerances {default.final_error:.6g} (rel "
              f"{default.final_error / best - 1:.1e}, {gap:.3f} mm, {default.iterations} "
              f"iterations, {default_s:.2f} s)")
        for name in args.optimizers.split(","):
            config = tight.with_(optimizer=name, max_iterations=100000,
                                 stopping=TIGHT.with_(relative_tol=1e-12, absolute_tol=1e-12))
            r = run_to_budget(problem, config, fast.theta, robot, args.budget)
            marks = " ".join(f"{'%d/%.1f' % r['first'][m[0]] if m[0] in r['first'] else '-':>13}"
                             for m in MILESTONES)
            print(f"{label + ' ' + name:<20} {marks} {r['stop']:>9} {r['iterations']:>6d} "
                  f"{r['seconds']:>6.1f} {1e3 * r['seconds'] / max(r['iterations'], 1):>6.1f} "
                  f"{r['rel']:>10.2e} {r['gap']:>8.3f}")

    print("\nTable 2: one GTSAM LM iteration (30 iterations from the initial trajectory)")
    print(f"{'case':<8} {'held ms/it':>10} {'copied ms/it':>12} {'lin calls':>9} "
          f"{'err calls':>9} {'Python ms':>9} {'rest ms':>8} {'C++ only ms':>11}")
    for label, problem in problems.items():
        held = [cost_breakdown(problem, True) for _ in range(3)]
        copied = [cost_breakdown(problem, False) for _ in range(3)]
        h = {k: float(np.median([x[k] for x in held])) for k in ("ms", "linearize", "error",
                                                               "python")}
        c = float(np.median([x["ms"] for x in copied]))
        cpp = pure_cpp_iteration(problem, held[-1]["values"])
        print(f"{label:<8} {h['ms']:>10.1f} {c:>12.1f} {h['linearize']:>9.0f} {h['error']:>9.0f} "
              f"{h['python']:>9.1f} {h['ms'] - h['python']:>8.1f} {cpp:>11.1f}")


if __name__ == "__main__":
    main()
