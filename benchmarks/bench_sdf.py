"""Signed distance field: build time (EDT and exact) and query time for 250 x 40 points.

Run: python benchmarks/bench_sdf.py  (prints medians over repeats).
"""
from __future__ import annotations


import numpy as np

from scenes import Box, Cylinder, Scene, Sphere, builtin_scene
from harness import median_seconds, print_environment



def main() -> None:
    print_environment()
    scenes = {
        "box_closing (1 box)": builtin_scene("box_closing"),
        "5 obstacles": Scene([Box([0.32, -0.32, 0.13], [0.09, 0.06, 0.28]),
                              Box([0.0, 0.0, -0.05], [1.4, 1.4, 0.1]),
                              Sphere([0.3, 0.3, 0.3], 0.1),
                              Cylinder([-0.3, 0.2, 0.2], 0.05, 0.4),
                              Box([-0.3, -0.4, 0.3], [0.1, 0.2, 0.1])]),
    }
    rng = np.random.default_rng(0)
    for label, scene in scenes.items():
        volume = float(np.prod(scene.bounds[1] - scene.bounds[0]))
        edt = median_seconds(lambda: scene.sdf(0.01), 5)
        exact = median_seconds(lambda: scene.sdf(0.01, exact=True), 3)
        sdf = scene.sdf(0.01)
        points = rng.uniform(scene.bounds[0], scene.bounds[1], (250, 40, 3))
        query = median_seconds(lambda: sdf.query(points), 20)
        analytic = median_seconds(lambda: scene.distance(points), 20)
        print(f"{label}: grid {sdf.shape} over {volume:.2f} m^3 at 1 cm")
        print(f"  build EDT   {edt * 1e3:8.1f} ms (median of 5)")
        print(f"  build exact {exact * 1e3:8.1f} ms (median of 3), ratio exact/EDT {exact / edt:.2f}")
        print(f"  query 250x40 points {query * 1e3:6.2f} ms (value + gradient, median of 20); "
              f"analytic distance only {analytic * 1e3:6.2f} ms")


if __name__ == "__main__":
    main()
