"""CLAMP planning benchmark: whole plan() calls, medians, against the reference C++ CLAMP.

Every timing is one complete ``plan()`` call (inverse-kinematics initialisation, the scene's
distance query, optimisation, posterior covariance, checks) with a scene object new to the
planner each time. Anchor: the reference C++ CLAMP (GTSAM + GPMP2) on box_closing, same
machine type: empty scene 1.68 s / 127 iterations, with the box 1.06 s / 79 iterations, about
13 ms per iteration (the issue measured ~27 ms side by side).

The header prints a machine reference (:func:`harness.machine_reference`: a fixed pure-Python
loop and a fixed numpy workload, timed in the same run): figures from two machines compare as
ratios to it.

Tables: box_closing on the Jaco and the Sawyer (empty, box, goal); the TLGC boundary family's
overhead; scaling with T (per-iteration time and time per state); BLAS threads unset vs 1;
optionally (--gtsam) GTSAM's own optimizers on the same graph from the same start.

    python benchmarks/bench_clamp.py [--repeats 5] [--quick] [--gtsam] [--pose]

The pose table (a pose prior against the position-only prior of the same demonstrations) runs
first; ``--pose`` runs it alone.
"""
from __future__ import annotations

import argparse
import statistics
import time
import warnings

import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

from harness import print_environment, print_machine_reference, shared_demonstrations

REFERENCE_START = np.array([0.2054, -0.4722, 0.2625])
REFERENCE_BOX = [0.32, -0.32, 0.13, 0.09, 0.06, 0.28]
CPP = {"empty": (1.68, 127), "box": (1.06, 79)}
CPP_MS_PER_ITERATION = 13.0
SAWYER_OFFSET = np.array([0.3, 0.0, 0.2])


def median_plan(make_call, repeats: int):
    """Run make_call()() ``repeats`` times (after two warm-ups); last result, median timings
    (the plan's own, wall clock) and under "cpu" the median CPU time [s] of the process per
    call (what other processes sharing the cores change least)."""
    make_call()()
    make_call()()
    results, cpu = [], []
    for _ in range(repeats):
        started = time.process_time()
        results.append(make_call()())
        cpu.append(time.process_time() - started)
    keys = set().union(*(r.timings for r in results))
    timings = {k: statistics.median(r.timings.get(k, 0.0) for r in results) for k in keys}
    return results[-1], {**timings, "cpu": statistics.median(cpu)}


HEADER = (f"{'case':<30} {'ok':<3} {'total ms':>9} {'x C++':>6} {'iters':>5} {'trials':>6} "
          f"{'ms/iter':>7} {'x13ms':>6} {'build':>6} {'optim':>6} {'cov':>5} {'cov %':>5} "
          f"{'final err':>10} {'clear mm':>8}  phases ms (lin/solve/corr/err)")


def row(label: str, r, t: dict, cpp: tuple[float, int] | None = None) -> str:
    per_iteration = 1e3 * t["optimize"] / max(r.iterations, 1)
    clearance = "inf" if not np.isfinite(r.min_clearance) else f"{1e3 * r.min_clearance:.1f}"
    ratio = f"{t['total'] / cpp[0]:.3f}" if cpp else ""
    phases = "/".join(f"{1e3 * t.get(k, 0.0):.0f}" for k in ("linearize", "solve", "correction",
                                                              "error"))
    return (f"{label:<30} {'yes' if r.success else 'no':<3} {1e3 * t['total']:>9.1f} {ratio:>6} "
            f"{r.iterations:>5d} {r.trials:>6d} {per_iteration:>7.2f} "
            f"{per_iteration / CPP_MS_PER_ITERATION:>6.2f} {1e3 * t['build']:>6.1f} "
            f"{1e3 * t['optimize']:>6.1f} {1e3 * t.get('marginals', 0):>5.1f} "
            f"{100 * t.get('marginals', 0) / t['total']:>5.1f} {r.final_error:>10.4g} "
            f"{clearance:>8}  {phases}")


def pose_table(repeats: int) -> None:
    """Whole plan() calls with a pose prior against the position-only prior of the same
    demonstrations (anchor: the position-only call, same skill, same start, same run): a
    synthetic pour through joint keyframes on each arm (tests/pose_demos.py, 6 demonstrations,
    60 states over 5 s, the wrist tilted 0.8 rad at the end), from the second demonstration's
    start configuration turned by 0.03 rad per joint, empty scene and a goal pose."""
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from clamp import learn_prior, plan
    from clamp.prior import so3
    from robots import load_robot
    from scenes import Demonstrations
    from tests.pose_demos import pose_demonstrations

    print(f"\nPose prior vs position-only prior (synthetic pour, medians of {repeats}); "
          "x pos = pose total / position-only total, wall clock and the process's CPU time")
    print(HEADER + "  x pos (wall, cpu)")
    for arm in ("jaco", "sawyer"):
        robot = load_robot(arm)
        demos = pose_demonstrations(robot, duration=5.0)
        pose = learn_prior(demos)
        position = learn_prior(Demonstrations(demos.positions, demos.velocities, demos.time))
        start = demos.joint_positions[1, 0] + 0.03
        end = np.eye(4)
        end[:3, :3] = so3.from_quaternions(pose.mean_quaternions()[-1]) @ so3.exp_map(
            [0.0, 0.1, 0.1])
        end[:3, 3] = pose.mean[-1, :3] + 0.02
        for case, goal, position_goal in (("empty", None, None), ("goal pose", end, end[:3, 3])):
            base, tb = median_plan(lambda: lambda: plan(position, robot, None, start,
                                                        goal=position_goal), repeats)
            print(row(f"{arm} {case} position-only", base, tb))
            r, t = median_plan(lambda: lambda: plan(pose, robot, None, start, goal=goal), repeats)
            print(row(f"{arm} {case} pose", r, t) + f"  {t['total'] / tb['total']:.2f}, "
                  f"{t['cpu'] / tb['cpu']:.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--quick", action="store_true", help="fewer scaling points")
    parser.add_argument("--gtsam", action="store_true", help="also GTSAM's optimizers (slow)")
    parser.add_argument("--pose", action="store_true",
                        help="only the pose prior's table (pose vs position-only prior)")
    args = parser.parse_args()
    print_environment()
    print_machine_reference()
    print("# BLAS:", ", ".join(f"{i['internal_api']} {i['num_threads']} threads"
                               for i in threadpool_info() if i["user_api"] == "blas"))
    warnings.simplefilter("ignore")
    pose_table(args.repeats)
    if args.pose:
        return
    from clamp import PlannerConfig, learn_prior, plan
    from robots import load_robot
    from scenes import Box, Scene, make_demonstrations

    demos = shared_demonstrations("box_closing")
    start = REFERENCE_START
    if demos is None:
        demos = make_demonstrations("box_closing")
        start = demos.positions[:, 0].mean(axis=0)
    prior = learn_prior(demos)
    jaco, sawyer = load_robot("jaco"), load_robot("sawyer")
    prior_s = learn_prior(demos.translated(SAWYER_OFFSET))

    def box(offset=np.zeros(3)):
        ref = np.array(REFERENCE_BOX)
        ref[:3] += offset
        return Scene([Box.from_reference(ref.tolist())])

    print(f"\nbox_closing (M={demos.M}, T={demos.T}), default PlannerConfig(), medians of "
          f"{args.repeats}; x C++ = our total / the C++ total")
    print(HEADER)
    goal = np.asarray(prior.mean)[-1, :3] + np.array([0.0, 0.03, 0.0])
    cases = [
        ("jaco empty", jaco, prior, lambda: None, start, None, CPP["empty"]),
        ("jaco box", jaco, prior, lambda: box(), start, None, CPP["box"]),
        ("jaco goal +3 cm y", jaco, prior, lambda: None, start, goal, None),
        ("sawyer empty", sawyer, prior_s, lambda: None, start + SAWYER_OFFSET, None, None),
        ("sawyer box", sawyer, prior_s, lambda: box(SAWYER_OFFSET), start + SAWYER_OFFSET,
         None, None),
    ]
    for label, robot, pr, scene, s, g, cpp in cases:
        r, t = median_plan(lambda: (lambda sc=scene(): plan(pr, robot, sc, s, goal=g)),
                           args.repeats)
        print(row(label, r, t, cpp))

    print("\nTLGC boundary family (python -m tlgc.demo_clamp_cylinder's plan, Jaco, 40 states)")
    from tlgc.boundary_factor import BoundaryFamily
    from tlgc.cylinder import fit_cylinder
    small = make_demonstrations("reach_from_above", num_demos=6, num_points=40, dt=1.0, seed=0)
    soft = learn_prior(small, jitter=1e-4)
    cylinder = fit_cylinder(small, "spline")
    s0 = cylinder.directrix[0] + 0.3 * cylinder.radius(0, 0.0) * cylinder.normals[0]
    end_radius = float(cylinder.radius(cylinder.num_sections - 1, 0.0))
    g0 = cylinder.directrix[-1] + (end_radius + 0.05) * cylinder.normals[-1]
    print(HEADER)
    plain, tp = median_plan(lambda: lambda: plan(soft, jaco, None, s0, goal=g0), args.repeats)
    print(row("without boundary", plain, tp))
    bounded, tb = median_plan(lambda: lambda: plan(
        soft, jaco, None, s0, goal=g0, extra_factors=[BoundaryFamily(cylinder, 40, sigma=0.005)]),
        args.repeats)
    print(row("with boundary", bounded, tb))
    print(f"boundary overhead: total x{tb['total'] / tp['total']:.2f}, per iteration "
          f"x{(tb['optimize'] / max(bounded.iterations, 1)) / (tp['optimize'] / max(plain.iterations, 1)):.2f}")

    print("\nScaling with T (Jaco, empty scene, resampled demonstrations); per state = ms per "
          "iteration / T, ratio against T = 250")
    print(HEADER + "  us/state/iter  ratio")
    base = None
    for T in ((250, 1000, 2000) if args.quick else (100, 250, 500, 1000, 2000)):
        prior_t = learn_prior(demos.resample(T))
        r, t = median_plan(lambda: lambda: plan(prior_t, jaco, None, start), max(2, args.repeats // 2))
        per_state = 1e6 * t["optimize"] / max(r.iterations, 1) / T
        base = per_state if T == 250 else base
        ratio = f"{per_state / base:.2f}" if base else ""
        print(row(f"T = {T}", r, t) + f"  {per_state:>12.1f}  {ratio:>5}")

    print("\nBLAS threads (Jaco box): default setting vs limited to 1 around the whole call")
    print(HEADER)
    r, t = median_plan(lambda: (lambda sc=box(): plan(prior, jaco, sc, start)), args.repeats)
    print(row("BLAS threads unset", r, t, CPP["box"]))

    def one_thread(sc=None):
        with threadpool_limits(limits=1, user_api="blas"):
            return plan(prior, jaco, sc if sc is not None else box(), start)
    r1, t1 = median_plan(lambda: one_thread, args.repeats)
    print(row("BLAS threads = 1", r1, t1, CPP["box"]))
    print(f"unset / 1 thread: x{t['total'] / t1['total']:.2f}")

    if args.gtsam:
        print("\nGTSAM's optimizers on problem.graph() from the same initial trajectory "
              "(default tolerances; one run each)")
        print(HEADER + "  EE vs fast [mm]")
        for label, sc in (("empty", None), ("box", box())):
            fast = plan(prior, jaco, sc, start)
            for name in ("gtsam", "gtsam_dogleg"):
                r = plan(prior, jaco, sc, start, config=PlannerConfig().with_(optimizer=name))
                gap = 1e3 * np.max(np.linalg.norm(r.ee_path - fast.ee_path, axis=1))
                print(row(f"{label} {name}", r, r.timings, CPP[label]) + f"  {gap:.2f}")


if __name__ == "__main__":
    main()
