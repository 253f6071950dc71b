"""Benchmark of TLGC generalization: median wall time of TPS (Algorithm 3) and LTE (Algorithm 4).

Cases: needle_threading.mat and pick_place.mat (4 demonstrations, N = 1500, spline sections;
skipped with a note when ../shared/datasets is absent) and a synthetic pick_place set (N = 250).
Each generalizes the cylinder to a goal moved by a near (5 cm) and a far (50 cm) offset,
keeping the start fixed, and prints the medians, the LTE/TPS time ratio and the shape
distortion of each result (relative change of the directrix's Laplacian coordinates).

Second table (issue 11, start anchoring): on each real data set and cross-section type, the
end is moved by 5 and 20 cm in the six axis directions with the start kept; for TPS and LTE
(default mode, and the similarity mode) it prints the largest displacement of the first
cross-section (centre and boundary) [mm], the largest turn of its plane or normal [deg], and
the share of 200 seeded starts from the old first section whose reproductions lie inside the
new cylinder.

Run: python benchmarks/bench_tlgc_generalization.py [--repeats 15]
"""
from __future__ import annotations

import argparse

import numpy as np

from scenes import make_demonstrations
from tlgc.cylinder import GeneralizedCylinder, fit_cylinder
from tlgc.reproduction import random_starts, reproduce
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


DIRECTIONS = np.array([[1.0, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])


def first_section_change(old: GeneralizedCylinder, new: GeneralizedCylinder) -> tuple[float, float]:
    """Largest displacement [m] of the first section's centre and boundary, turn [deg]."""
    ring = np.linalg.norm(new.boundary_points(64, [0]) - old.boundary_points(64, [0]), axis=-1)
    move = max(float(ring.max()), float(np.linalg.norm(new.directrix[0] - old.directrix[0])))
    turn = max(np.degrees(np.arccos(np.clip(new.tangents[0] @ old.tangents[0], -1, 1))),
               np.degrees(np.arccos(np.clip(new.normals[0] @ old.normals[0], -1, 1))))
    return move, float(turn)


def start_anchoring_table() -> None:
    print("\nstart kept, end moved 5 / 20 cm in 6 directions (12 moves): worst over the moves")
    print(f"{'data set':<17} {'type':<8} {'method':<15} {'move [mm]':>10} {'tilt [deg]':>11} "
          f"{'inside [%]':>11}")
    for name in ("needle_threading", "pick_place"):
        demos = shared_demonstrations(name)
        if demos is None:
            continue
        for kind in ("circle", "ellipse", "spline"):
            cyl = fit_cylinder(demos, kind)
            starts = random_starts(cyl, 200, rng=np.random.default_rng(21))
            source = cyl.directrix[[0, -1]]
            methods = {"TPS": lambda t: tps_generalize(cyl, source, t),
                       "LTE": lambda t: lte_generalize(cyl, landmark_constraints(cyl, source, t)),
                       "LTE similarity": lambda t: lte_generalize(
                           cyl, landmark_constraints(cyl, source, t), mode="similarity")}
            for label, method in methods.items():
                worst = [0.0, 0.0, 100.0]
                for distance in (0.05, 0.20):
                    for direction in DIRECTIONS:
                        target = source + np.stack([np.zeros(3), distance * direction])
                        new = method(target)
                        move, tilt = first_section_change(cyl, new)
                        reps = reproduce(new, starts)
                        inside = 100.0 * new.contains(reps.reshape(-1, 3)).mean()
                        worst = [max(worst[0], move), max(worst[1], tilt), min(worst[2], inside)]
                print(f"{name:<17} {kind:<8} {label:<15} {worst[0] * 1e3:10.2e} {worst[1]:11.2e} "
                      f"{worst[2]:11.2f}")


if __name__ == "__main__":
    main()
    start_anchoring_table()
