"""Start anchoring of TLGC generalization (issue 11): the table of end moves.

Run:  python benchmarks/bench_tlgc_start_anchor.py [--kinds circle ellipse spline]

On needle_threading.mat and pick_place.mat (skipped with a note when ../shared/datasets is
absent) the directrix end is moved by 5 and 20 cm in the six axis directions, the start kept
(the default), by TPS (:func:`tlgc.tps_generalize`) and LTE (:func:`tlgc.lte_generalize`,
default mode). Per move and cross-section type it prints:

* move [mm]: largest displacement of the first cross-section (its centre and 64 boundary
  points, old vs new, in world coordinates); target <= 1 mm;
* tilt [deg]: largest turn of the first section's plane (tangent) or of its normal; target
  <= 0.1 deg;
* end [mm]: distance of the new directrix end from its target (the move was made, not
  skipped);
* in: how many of 200 seeded starts (uniform in area inside the OLD first section) are
  accepted by :func:`tlgc.reproduce` on the new cylinder and reproduce with every one of
  their points inside it (:meth:`GeneralizedCylinder.contains`); target 200.

The figures are measured from the two cylinders' geometry, not taken from the generalization's
own bookkeeping. Not a timing benchmark.
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

from tlgc import (CROSS_SECTION_TYPES, GeneralizedCylinder, TLGCError, fit_cylinder,
                  random_starts, reproduce)
from tlgc.generalization import landmark_constraints, lte_generalize, tps_generalize
from harness import print_environment, shared_demonstrations

DIRECTIONS = {"+x": [1.0, 0, 0], "-x": [-1.0, 0, 0], "+y": [0, 1.0, 0], "-y": [0, -1.0, 0],
              "+z": [0, 0, 1.0], "-z": [0, 0, -1.0]}
DISTANCES = (0.05, 0.20)
STARTS = 200


def first_section_change(old: GeneralizedCylinder, new: GeneralizedCylinder) -> tuple[float, float]:
    """Largest displacement [m] of the first section's centre and boundary, largest turn [deg]
    of its tangent or normal."""
    ring = np.linalg.norm(new.boundary_points(64, [0]) - old.boundary_points(64, [0]), axis=-1)
    move = max(float(ring.max()), float(np.linalg.norm(new.directrix[0] - old.directrix[0])))
    turn = [np.arctan2(np.linalg.norm(np.cross(a, b)), a @ b)       # accurate near 0, unlike arccos
            for a, b in ((new.tangents[0], old.tangents[0]), (new.normals[0], old.normals[0]))]
    return move, float(np.degrees(max(turn)))


def starts_inside(new: GeneralizedCylinder, starts: np.ndarray) -> int:
    """How many starts (S, 3) reproduce on ``new`` with every point inside it."""
    count = 0
    for start in starts:
        try:
            path = reproduce(new, start)
        except TLGCError:               # refused: off the new first plane or outside it
            continue
        count += bool(new.contains(path).all())
    return count


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kinds", nargs="+", default=sorted(CROSS_SECTION_TYPES),
                        choices=sorted(CROSS_SECTION_TYPES))
    args = parser.parse_args(argv)
    print_environment()
    head = "".join(f" | {kind:^33s}" for kind in args.kinds)
    sub = "".join(f" | {'move[mm]':>9s} {'tilt[deg]':>9s} {'end[mm]':>8s} {'in':>4s}"
                  for _ in args.kinds)
    worst = {}
    for name in ("needle_threading", "pick_place"):
        demos = shared_demonstrations(name)
        if demos is None:
            continue
        cylinders = {kind: fit_cylinder(demos, kind) for kind in args.kinds}
        starts = {kind: random_starts(c, STARTS, rng=np.random.default_rng(21))
                  for kind, c in cylinders.items()}
        print(f"\n{name}: end moved, start kept; {STARTS} seeded starts in the old first section")
        print(f"{'method':6s} {'move':>9s}" + head)
        print(f"{'':6s} {'':>9s}" + sub)
        for method in ("TPS", "LTE"):
            for distance in DISTANCES:
                for label, direction in DIRECTIONS.items():
                    row = f"{method:6s} {f'{distance * 100:.0f} cm {label}':>9s}"
                    for kind, cyl in cylinders.items():
                        source = cyl.directrix[[0, -1]]
                        target = source + np.stack([np.zeros(3), distance * np.asarray(direction)])
                        if method == "TPS":
                            new = tps_generalize(cyl, source, target)
                        else:
                            new = lte_generalize(cyl, landmark_constraints(cyl, source, target))
                        move, tilt = first_section_change(cyl, new)
                        end = float(np.linalg.norm(new.directrix[-1] - target[1]))
                        inside = starts_inside(new, starts[kind])
                        key = (name, method)
                        w = worst.setdefault(key, [0.0, 0.0, STARTS])
                        w[:] = [max(w[0], move), max(w[1], tilt), min(w[2], inside)]
                        row += f" | {move * 1e3:9.2e} {tilt:9.2e} {end * 1e3:8.1e} {inside:4d}"
                    print(row)
    print("\nworst over moves and cross-section types (targets: <= 1 mm, <= 0.1 deg, 200):")
    for (name, method), (move, tilt, inside) in worst.items():
        print(f"  {name:17s} {method}: move {move * 1e3:.2e} mm, tilt {tilt:.2e} deg, "
              f"{inside}/{STARTS} starts inside")
    return 0


if __name__ == "__main__":
    sys.exit(main())
