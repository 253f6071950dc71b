"""Benchmark: TLGC reproduction and containment time against the BLAS thread setting.

Run:  python benchmarks/bench_tlgc_threads.py [--repeats 15] [--rounds 3]

Each setting runs in a fresh child process (thread counts are read when OpenBLAS loads):
OPENBLAS_NUM_THREADS / OMP_NUM_THREADS unset (OpenBLAS's default, one thread per core), both
set to 1, and both set to 4 x the core count (oversubscribed, which stands in for a many-core
machine's default on a small one). Reproduction multiplies per block with inner dimension 2;
before issue 11 a threaded BLAS made that 20x slower (2.0-2.4 s instead of 0.10-0.12 s). tlgc
now writes those products element-wise and runs its hot loops under
``scenes.threads.single_blas_thread`` (threadpoolctl), so every column should match the
single-thread one within noise (target: within 10 %). Uses ../shared/datasets when present,
synthetic stand-ins otherwise. Prints, per case, the best over interleaved rounds of the median
milliseconds, and the ratio to the 1-thread run.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

import numpy as np

SETTINGS = {"unset": None, "1 thread": "1", "oversubscribed": str(4 * (os.cpu_count() or 1))}
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def child(repeats: int) -> dict[str, float]:
    """Median times [ms] in this process: {case: ms}."""
    from scenes import make_demonstrations
    from tlgc import fit_cylinder, random_starts, reproduce
    from harness import median_ms, shared_demonstrations

    out = {}
    for name in ("needle_threading", "pick_place"):
        demos = shared_demonstrations(name)
        if demos is None:
            demos = make_demonstrations(name, num_demos=4, num_points=1500, seed=0)
        for kind in ("circle", "spline"):
            cyl = fit_cylinder(demos, kind)
            starts = random_starts(cyl, 1000, rng=0)
            out[f"{name} {kind} reproduce 1000"] = median_ms(lambda: reproduce(cyl, starts), repeats)
            out[f"{name} {kind} reproduce 10"] = median_ms(lambda: reproduce(cyl, starts[:10]), repeats)
            points = reproduce(cyl, starts[:20]).reshape(-1, 3)
            out[f"{name} {kind} contain 30k"] = median_ms(lambda: cyl.containment(points),
                                                          max(3, repeats // 3))
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        print(json.dumps(child(args.repeats)))
        return 0
    from harness import print_environment

    print_environment()
    runs: dict[str, list[dict[str, float]]] = {label: [] for label in SETTINGS}
    for _ in range(args.rounds):             # settings interleaved, so load drifts hit all alike
        for label, value in SETTINGS.items():
            env = {k: v for k, v in os.environ.items() if k not in THREAD_VARIABLES}
            if value is not None:
                env.update({k: value for k in THREAD_VARIABLES})
            run = subprocess.run([sys.executable, os.path.abspath(__file__), "--child",
                                  "--repeats", str(args.repeats)],
                                 env=env, capture_output=True, text=True, check=True,
                                 cwd=os.path.dirname(os.path.abspath(__file__)))
            runs[label].append(json.loads(run.stdout.strip().splitlines()[-1]))
    results = {label: {case: float(np.min([r[case] for r in rs])) for case in rs[0]}
               for label, rs in runs.items()}
    print(f"best of {args.rounds} interleaved rounds, each a median of {args.repeats} calls")
    cases = list(results["1 thread"])
    head = f"{'case':38s}" + "".join(f"{label + ' [ms]':>22s}" for label in SETTINGS)
    print(head + f"{'unset/1':>9s}{'over/1':>8s}")
    ratios = []
    for case in cases:
        row = [results[label][case] for label in SETTINGS]
        ratio_unset, ratio_over = row[0] / row[1], row[2] / row[1]
        ratios.append((ratio_unset, ratio_over))
        print(f"{case:38s}" + "".join(f"{t:22.2f}" for t in row)
              + f"{ratio_unset:9.2f}{ratio_over:8.2f}")
    ratios = np.array(ratios)
    print(f"largest ratio to the 1-thread time: unset {ratios[:, 0].max():.2f}, "
          f"oversubscribed {ratios[:, 1].max():.2f} (target <= 1.10)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
