"""Benchmark of TLGC generalization: median wall time of TPS (Algorithm 3) and LTE (Algorithm 4).

Cases: needle_threading.mat and pick_place.mat (4 demonstrations, N = 1500, spline sections;
skipped with a note when ../shared/datasets is absent) and a synthetic pick_place set (N = 250).
Each generalizes the cylinder to a goal moved by a near (5 cm) and a far (50 cm) offset,
keeping the start fixed, and prints the medians, the LTE/TPS time ratio and the shape
distortion of each result (relative change of the directrix's Laplacian coordinates).

The start-anchoring table (issue 11) is benchmarks/bench_tlgc_start_anchor.py.

Run: python benchmarks/bench_tlgc_generalization.py [--repeats 15]
"""
from __future__ import annotations

import argparse

import numpy as np

from scenes import make_demonstrations
from tlgc.cylinder import GeneralizedCylinder, fit_cylinder
from tlgc.generalization import (landmark_constraints, lte_generalize, shape_distortion,
                                 tps_generalize)
from harness import median_ms, print_environment, shared_demonstrations

OFFSETS = {"near": np.array([0.03, 0.04, 0.0]), "far": np.array([0.30, 0.35, 0.20])}



def cylinders() -> dict[str, GeneralizedCylinder]:
    out = {}
    for name in ("needle_threading", "pick_place"):
        demos = shared_demonstrations(name)
        if demos is not None:
            out[name] = fit_cylinder(demos, "spline")
    out["synthetic pick_place"] = fit_cylinder(make_demonstrations("pick_place", num_demos=5,
                                                                   num_points=250, seed=0), "spline")
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=15)
    args = parser.parse_args()
    print_environment()
    print(f"{'case':<22} {'goal':<5} {'N':>5} {'TPS ms':>8} {'LTE ms':>8} {'LTE/TPS':>8} "
          f"{'TPS dist':>9} {'LTE dist':>9}")
    for name, cyl in cylinders().items():
        source = cyl.directrix[[0, -1]]
        for label, offset in OFFSETS.items():
            target = source + np.stack([np.zeros(3), offset])
            constraints = landmark_constraints(cyl, source, target)
            t_tps = median_ms(lambda: tps_generalize(cyl, source, target), args.repeats)
            t_lte = median_ms(lambda: lte_generalize(cyl, constraints), args.repeats)
            d_tps = shape_distortion(cyl.directrix, tps_generalize(cyl, source, target).directrix)
            d_lte = shape_distortion(cyl.directrix, lte_generalize(cyl, constraints).directrix)
            print(f"{name:<22} {label:<5} {cyl.num_sections:>5} {t_tps:8.2f} {t_lte:8.2f} "
                  f"{t_lte / t_tps:8.2f} {d_tps:9.4f} {d_lte:9.2e}")


if __name__ == "__main__":
    main()
