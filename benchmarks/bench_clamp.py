"""CLAMP benchmarks: learning, build and optimisation times, iterations, errors, clearance.

Prints tables (medians over --repeats runs) for box_closing (../shared/datasets, else the
built-in synthetic skill): Jaco in an empty scene and with the reference's new box obstacle,
both initialisations and both optimisers; the Sawyer; scaling with the number of support
states T (resampled demonstrations) and with the number of obstacles. Ratios are against the
reference C++ (GTSAM + GPMP2) figures on box_closing: empty 1.68 s / 127 iterations, with the
obstacle 1.06 s / 79 iterations, about 13 ms per iteration for 250 support states.

Columns trials .. err (lean optimizer): solved trial steps (accepted + rejected) and the
milliseconds spent linearizing, solving (banded Cholesky of the damped normal equations, QR
fallback), correcting trial points and
evaluating the error (see clamp.levenberg_marquardt.LMOutcome.timings).

Rows "reference" use PlannerConfig.reference() (the reference's optimizer: plain LM, Cholesky,
lambda0 1e3, relative tolerance 1e-5; sigma_obs 0.05), "defaults" PlannerConfig() (workspace
correction, banded solver, gain-ratio damping); "straight_line" is the reference's initialisation.

    python benchmarks/bench_clamp.py [--repeats 3] [--quick]
"""
from __future__ import annotations

import argparse
import statistics
import time
import warnings

import numpy as np

from clamp.learning import learn_prior
from clamp.planner import PlannerConfig, plan
from harness import median_seconds, print_environment, shared_demonstrations

REFERENCE_START = np.array([0.2054, -0.4722, 0.2625])
REFERENCE_BOX = [0.32, -0.32, 0.13, 0.09, 0.06, 0.28]
CPP = {"empty": (1.68, 127), "obstacle": (1.06, 79)}
CPP_MS_PER_ITERATION = 13.0
SAWYER_OFFSET = np.array([0.3, 0.0, 0.2])


def load_skill():
    from scenes import make_demonstrations
    demos = shared_demonstrations("box_closing")
    if demos is None:
        print("# using the synthetic box_closing skill instead")
        demos = make_demonstrations("box_closing")
        return demos, demos.positions[:, 0].mean(axis=0)
    return demos, REFERENCE_START


def median_runs(fn, repeats: int):
    """Run fn() repeats times; return the last result and the median of its timings."""
    results = [fn() for _ in range(repeats)]
    keys = results[-1].timings.keys()
    med = {k: statistics.median(r.timings.get(k, 0.0) for r in results) for k in keys}
    return results[-1], med


def row(label: str, r, t: dict, cpp: tuple[float, int] | None = None,
        final: np.ndarray | None = None) -> str:
    """One table line; final (3,) = the demonstrations' mean final position for 'end mm'."""
    per_iteration = 1e3 * t["optimize"] / max(r.iterations, 1)
    planning = t["build"] + t["optimize"]
    clearance = "inf" if not np.isfinite(r.min_clearance) else f"{1e3 * r.min_clearance:.1f}"
    end = "" if final is None else f"{1e3 * np.linalg.norm(r.ee_path[-1] - final):.1f}"
    text = (f"{label:<34} {'yes' if r.success else 'no':<4} {1e3 * t['build']:>8.1f} "
            f"{1e3 * t['optimize']:>9.1f} {1e3 * planning:>9.1f} {r.iterations:>6d} "
            f"{per_iteration:>8.1f} {per_iteration / CPP_MS_PER_ITERATION:>6.2f} "
            f"{r.final_error:>10.4g} {clearance:>8} {1e3 * r.start_error:>8.3f} {end:>7}")
    text += f" {planning / cpp[0]:>8.2f} {r.iterations / cpp[1]:>7.2f}" if cpp is not None \
        else f" {'':>8} {'':>7}"
    if "linearize" in t:  # lean optimizer: trials and ms per phase
        text += (f" {r.trials:>6d} {1e3 * t['linearize']:>5.0f} {1e3 * t['solve']:>5.0f} "
                 f"{1e3 * t['correction']:>5.0f} {1e3 * t['error']:>5.0f}")
    return text


HEADER = (f"{'case':<34} {'ok':<4} {'build ms':>8} {'optim ms':>9} {'total ms':>9} {'iters':>6} "
          f"{'ms/iter':>8} {'x13ms':>6} {'final err':>10} {'clear mm':>8} {'start mm':>8} "
          f"{'end mm':>7} {'t/C++':>8} {'it/C++':>7} {'trials':>6} {'lin':>5} {'solve':>5} "
          f"{'corr':>5} {'err':>5}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="fewer scaling points")
    args = parser.parse_args()
    print_environment()
    warnings.simplefilter("ignore")
    from robots import load_robot
    from scenes import Box, Scene, Sphere

    demos, start = load_skill()
    jaco = load_robot("jaco")
    jaco.sphere_centres(np.zeros((1, jaco.n)))  # build the sphere model outside the timings

    learn_seconds = median_seconds(lambda: learn_prior(demos), max(args.repeats, 3))
    prior = learn_prior(demos)
    print(f"learning box_closing (M={demos.M}, T={demos.T}): median "
          f"{1e3 * learn_seconds:.1f} ms")

    scene = Scene([Box.from_reference(REFERENCE_BOX)])
    t0 = time.perf_counter()
    sdf = scene.sdf(0.01)
    print(f"SDF of the obstacle scene (1 cm cells, {sdf.shape}): {1e3 * (time.perf_counter() - t0):.0f} ms"
          " (built once, outside the planning timings)")
    final = demos.positions[:, -1].mean(axis=0)

    print("\nJaco, box_closing (planning = build incl. initialisation + optimisation; medians; "
          "end mm = final position vs the demonstrations' mean)")
    print(HEADER)
    cases = [("reference", init, "lean") for init in ("straight_line", "prior_mean")]
    cases += [("reference", "prior_mean", "gtsam")]
    cases += [("defaults", init, "lean") for init in ("prior_mean", "straight_line")]
    for scene_name, sc in (("empty", None), ("obstacle", scene)):
        for settings, init, optimizer in cases:
            if optimizer == "gtsam" and sc is not None and args.quick:
                continue
            make = PlannerConfig.reference if settings == "reference" else PlannerConfig
            config = make(initialisation=init, optimizer=optimizer)
            slow = settings == "reference" and sc is not None  # ~500 iterations, ~10 s
            r, t = median_runs(lambda: plan(prior, jaco, sc, start, config=config,
                                            sdf=sdf if sc is not None else None),
                               1 if slow else args.repeats)
            print(row(f"{scene_name} {settings} {init} {optimizer}", r, t, CPP[scene_name], final))
    for init in ("prior_mean", "straight_line"):
        for sc_name, sc in (("empty", None), ("obstacle", scene)):
            config = PlannerConfig.fast(initialisation=init)
            r, t = median_runs(lambda: plan(prior, jaco, sc, start, config=config,
                                            sdf=sdf if sc is not None else None), args.repeats)
            print(row(f"{sc_name} {init} FAST", r, t, CPP[sc_name], final))
    r = plan(prior, jaco, scene, start, config=PlannerConfig(obstacle_factors=False))
    print(f"{'obstacle scene, no obstacle factors':<34} min clearance {1e3 * r.min_clearance:.1f} mm "
          f"({'collides' if r.min_clearance < 0 else 'free'})")
    print("straight_line init: the two configurations are IK of the start and of the prior's "
          "mean final position (= the demonstrations' mean final position); the reference's DH "
          "joint configurations do not transfer to the URDF.")

    print("\nSawyer, box_closing translated by", SAWYER_OFFSET.tolist(), "m")
    sawyer = load_robot("sawyer")
    sawyer.sphere_centres(np.zeros((1, sawyer.n)))
    moved = demos.translated(SAWYER_OFFSET)
    prior_s = learn_prior(moved)
    print(HEADER)
    for sc_name, sc in (("empty", None),):
        r, t = median_runs(lambda: plan(prior_s, sawyer, sc, start + SAWYER_OFFSET), args.repeats)
        print(row(f"sawyer {sc_name} prior_mean lean", r, t))

    print("\nScaling with T (Jaco, empty scene, prior_mean init, resampled demonstrations)")
    print(HEADER)
    sizes = (50, 250, 1000) if args.quick else (50, 100, 250, 500, 1000)
    for T in sizes:
        resampled = demos.resample(T)
        prior_t = learn_prior(resampled)
        r, t = median_runs(lambda: plan(prior_t, jaco, None, start), args.repeats)
        print(row(f"T = {T}", r, t))

    print("\nScaling with the number of obstacles (Jaco, T = 250, prior_mean init, "
          "PlannerConfig.fast(); the reference box plus spheres of 4 cm behind the robot: "
          "the SDF makes the cost per iteration independent of the obstacle count)")
    print(HEADER)
    rng = np.random.default_rng(0)
    far = [Sphere(c, 0.04) for c in rng.uniform([-0.6, 0.2, 0.0], [-0.2, 0.6, 0.5], size=(16, 3))]
    for count in ((0, 1, 4) if args.quick else (0, 1, 2, 4, 8, 16)):
        obstacles = [Box.from_reference(REFERENCE_BOX)] + far[:count]
        sc = Scene(obstacles, bounds=scene.bounds)
        t0 = time.perf_counter()
        sdf_k = sc.sdf(0.01)
        sdf_seconds = time.perf_counter() - t0
        r = plan(prior, jaco, sc, start, config=PlannerConfig.fast(), sdf=sdf_k)
        print(row(f"{count + 1} obstacles (sdf {1e3 * sdf_seconds:.0f} ms)", r, r.timings))


if __name__ == "__main__":
    main()
