"""Benchmark of TLGC fitting and reproduction (medians), against the MATLAB reference figures.

Run:  python benchmarks/bench_tlgc.py [--repeats 7]

Uses ../shared/datasets/{needle_threading,pick_place}.mat (4 demonstrations x 1500 points) when
present, otherwise synthetic stand-ins of the same size. Prints, per data set and
cross-section type, the median fit time, the median time of 1 / 100 / 1000 reproductions from
seeded random starts, the fraction of reproduced points inside the cylinder (each point
against its own cross-section, and by the containment query, which finds the section whose
plane holds the point) and the containment time of 100 reproductions (150k points) in ms.
Targets: fit < 100 ms; 1000 spline reproductions < 50 ms.
"""
from __future__ import annotations

import argparse
import os
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


def load(name: str) -> np.ndarray:
    """Demonstrations (M, 1500, 3): the shared data set, or a synthetic stand-in."""
    demos = shared_demonstrations(name)
    if demos is not None:
        return demos.positions
    print(f"  (synthetic '{name}' stand-in)")
    return make_demonstrations(name, num_demos=4, num_points=1500, seed=0).positions



def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args(argv)
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
    return 0


if __name__ == "__main__":
    sys.exit(main())
