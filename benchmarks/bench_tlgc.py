"""Benchmark of TLGC fitting and reproduction (medians), against the MATLAB reference figures.

Run:  python benchmarks/bench_tlgc.py [--repeats 7]

Uses ../shared/datasets/{needle_threading,pick_place}.mat (4 demonstrations x 1500 points) when
present, otherwise synthetic stand-ins of the same size. Prints, per data set and
cross-section type, the median fit time, the median time of 1 / 100 / 1000 reproductions from
seeded random starts, the fraction of reproduced points inside the cylinder (each point
against its own cross-section, and by the containment query, which finds the section whose
plane holds the point) and the containment time of 100 reproductions (150k points) in ms.
Targets: fit < 100 ms; 1000 spline reproductions < 50 ms.

Then (skip with --no-threads) the BLAS thread table (issue 11): fit, 10 and 1000 reproductions
and a 30k-point containment query, each setting in a fresh child process (thread counts are
read when OpenBLAS loads): OPENBLAS_NUM_THREADS / OMP_NUM_THREADS / MKL_NUM_THREADS unset
(OpenBLAS's default, one thread per core), all set to 1, and all set to 4 x the core count
(oversubscribed, standing in for a many-core machine's default on a small one). Before issue 11
a threaded BLAS made reproduction 20x slower (2.0-2.4 s instead of 0.10-0.12 s); tlgc now runs
its hot loops under ``skillplan.threads.single_blas_thread``, so every column should be within
10 % of the 1-thread one. Prints the best over interleaved rounds of the median [ms] and the
ratios to the 1-thread time. Timings on a shared machine are noisy.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

import numpy as np

from scenes import make_demonstrations
from tlgc import fit_cylinder, random_starts, reproduce
from harness import median_ms, print_environment, shared_demonstrations

# Reference implementation (MATLAB, rezaahmadzadeh/TLGC) on the same data, as reported for it
# (seconds, low-high), used for the speed-up ratios printed at the end.
REFERENCE_SECONDS = {("fit", "circle"): (0.36, 0.44), ("fit", "spline"): (2.7, 3.0),
                     ("10 reproductions", "circle"): (0.19, 0.23),
                     ("10 reproductions", "spline"): (10.0, 12.6)}
REFERENCE = {
    "fit circle": "0.36-0.44 s",
    "fit spline": "2.7-3.0 s",
    "10 reproductions circle": "0.19-0.23 s",
    "10 reproductions spline": "10-12.6 s",
    "inside spline needle_threading": "93.8 %",
    "inside spline pick_place": "99.5 %",
}
KINDS = ("circle", "ellipse", "spline")
COUNTS = (1, 10, 100, 1000)
THREAD_SETTINGS = {"unset": None, "1 thread": "1", "oversubscribed": str(4 * (os.cpu_count() or 1))}
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def load(name: str) -> np.ndarray:
    """Demonstrations (M, 1500, 3): the shared data set, or a synthetic stand-in."""
    demos = shared_demonstrations(name)
    if demos is not None:
        return demos.positions
    print(f"  (synthetic '{name}' stand-in)")
    return make_demonstrations(name, num_demos=4, num_points=1500, seed=0).positions



def thread_case_times(repeats: int) -> dict[str, float]:
    """Median times [ms] in this process: {case: ms} (the child of :func:`thread_table`)."""
    out = {}
    for name in ("needle_threading", "pick_place"):
        demos = load(name)
        for kind in ("circle", "spline"):
            out[f"{name} {kind} fit"] = median_ms(lambda: fit_cylinder(demos, kind), repeats)
            cyl = fit_cylinder(demos, kind)
            starts = random_starts(cyl, 1000, rng=0)
            out[f"{name} {kind} reproduce 10"] = median_ms(lambda: reproduce(cyl, starts[:10]), repeats)
            out[f"{name} {kind} reproduce 1000"] = median_ms(lambda: reproduce(cyl, starts), repeats)
            points = reproduce(cyl, starts[:20]).reshape(-1, 3)
            out[f"{name} {kind} contain 30k"] = median_ms(lambda: cyl.containment(points),
                                                          max(3, repeats // 3))
    return out


def thread_table(repeats: int, rounds: int) -> None:
    """Print the BLAS thread table (module docstring)."""
    runs: dict[str, list[dict[str, float]]] = {label: [] for label in THREAD_SETTINGS}
    for _ in range(rounds):                  # settings interleaved, so load drifts hit all alike
        for label, value in THREAD_SETTINGS.items():
            env = {k: v for k, v in os.environ.items() if k not in THREAD_VARIABLES}
            if value is not None:
                env.update({k: value for k in THREAD_VARIABLES})
            here = os.path.dirname(os.path.abspath(__file__))
            run = subprocess.run([sys.executable, os.path.abspath(__file__), "--child",
                                  "--repeats", str(repeats)],
                                 env=env, capture_output=True, text=True, check=True, cwd=here)
            runs[label].append(json.loads(run.stdout.strip().splitlines()[-1]))
    best = {label: {case: float(np.min([r[case] for r in rs])) for case in rs[0]}
            for label, rs in runs.items()}
    print(f"\nBLAS threads: best of {rounds} interleaved rounds, each a median of {repeats} calls")
    print(f"  {'case':36s}" + "".join(f"{label + ' [ms]':>20s}" for label in THREAD_SETTINGS)
          + f"{'unset/1':>9s}{'over/1':>8s}")
    ratios = []
    for case in best["1 thread"]:
        row = [best[label][case] for label in THREAD_SETTINGS]
        ratios.append((row[0] / row[1], row[2] / row[1]))
        print(f"  {case:36s}" + "".join(f"{t:20.2f}" for t in row)
              + f"{ratios[-1][0]:9.2f}{ratios[-1][1]:8.2f}")
    ratios_arr = np.array(ratios)
    print(f"  largest ratio to the 1-thread time: unset {ratios_arr[:, 0].max():.2f}, "
          f"oversubscribed {ratios_arr[:, 1].max():.2f} (target <= 1.10)")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--rounds", type=int, default=3, help="interleaved rounds per thread setting")
    parser.add_argument("--no-threads", action="store_true", help="skip the BLAS thread table")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        print(json.dumps(thread_case_times(args.repeats)))
        return 0
    print_environment()
    print(f"TLGC benchmark, median of {args.repeats} runs (numpy {np.__version__}, "
          f"{os.cpu_count()} cpus)")
    ours: dict[tuple[str, str, str], float] = {}
    for name in ("needle_threading", "pick_place"):
        demos = load(name)
        print(f"\n{name}: M={demos.shape[0]} N={demos.shape[1]}")
        print(f"  {'type':8s} {'fit [ms]':>9s} " + " ".join(f"{f'{c} rep [ms]':>13s}" for c in COUNTS)
              + f" {'inside [%]':>11s} {'contain [%]':>11s} {'150k pts':>10s}")
        for kind in KINDS:
            t_fit = median_ms(lambda: fit_cylinder(demos, kind), args.repeats)
            ours[name, "fit", kind] = t_fit
            cyl = fit_cylinder(demos, kind)
            starts = random_starts(cyl, max(COUNTS), rng=0)
            t_rep = [median_ms(lambda: reproduce(cyl, starts[:c]), args.repeats) for c in COUNTS]
            ours[name, "10 reproductions", kind] = t_rep[COUNTS.index(10)]
            reps = reproduce(cyl, starts)
            inside = cyl.ratio(reps, np.arange(cyl.num_sections)[None, :]) <= 1.0 + 1e-9
            t_cont = median_ms(lambda: cyl.containment(reps[:100].reshape(-1, 3)), 3)
            found = cyl.containment(reps.reshape(-1, 3)).inside
            print(f"  {kind:8s} {t_fit:9.2f} " + " ".join(f"{t:13.2f}" for t in t_rep)
                  + f" {100 * inside.mean():11.2f} {100 * found.mean():11.2f} {t_cont:10.1f}")
    print("\nMATLAB reference (same data): " + "; ".join(f"{k}: {v}" for k, v in REFERENCE.items()))
    print("speed-up over the reference (reference time / our median):")
    for (task, kind), (low, high) in REFERENCE_SECONDS.items():
        for name in ("needle_threading", "pick_place"):
            ms = ours[name, task, kind]
            print(f"  {task:16s} {kind:7s} {name:17s} ours {ms:8.2f} ms  reference {low:g}-{high:g} s"
                  f"  -> x{1e3 * low / ms:,.0f}-{1e3 * high / ms:,.0f}")
    if not args.no_threads:
        thread_table(args.repeats, args.rounds)
    return 0


if __name__ == "__main__":
    sys.exit(main())
