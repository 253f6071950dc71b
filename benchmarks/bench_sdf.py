"""Signed distance: the analytic Scene.query (exact, with gradient) against the grid field
(build once, then trilinear queries) for 7500 points (e.g. 250 support states x 30 spheres).

Run: python benchmarks/bench_sdf.py  (prints medians over repeats; never asserts on time).
Scenes: the box_closing box (1 obstacle), 5 mixed obstacles, 17 mixed obstacles (boxes, some
rotated, spheres, tilted cylinders, capsules; seeded).
"""
from __future__ import annotations

import numpy as np

from scenes import Box, Capsule, Cylinder, Scene, SignedDistanceField, Sphere, builtin_scene
from harness import median_seconds, print_environment

POINTS = 7500
CELL = 0.01


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    """A proper rotation (3,3) from the QR of a Gaussian matrix."""
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q * np.linalg.det(q)


def mixed_scene(count: int, seed: int = 0) -> Scene:
    """``count`` obstacles cycling box, rotated box, sphere, tilted cylinder, capsule, placed
    uniformly in the default workspace (sizes 3-15 cm)."""
    rng = np.random.default_rng(seed)
    obstacles = []
    for k in range(count):
        centre = rng.uniform([-0.6, -0.6, 0.0], [0.6, 0.6, 0.6])
        kind = k % 5
        if kind == 0:
            obstacles.append(Box(centre, rng.uniform(0.03, 0.15, 3)))
        elif kind == 1:
            obstacles.append(Box(centre, rng.uniform(0.03, 0.15, 3), random_rotation(rng)))
        elif kind == 2:
            obstacles.append(Sphere(centre, rng.uniform(0.03, 0.1)))
        else:
            kind_class = Cylinder if kind == 3 else Capsule
            obstacles.append(kind_class(centre, rng.uniform(0.02, 0.06), rng.uniform(0.05, 0.3),
                                        rng.normal(size=3)))
    return Scene(obstacles)


def main() -> None:
    print_environment()
    scenes = {
        "1 obstacle (box_closing)": builtin_scene("box_closing"),
        "5 obstacles": Scene([Box([0.32, -0.32, 0.13], [0.09, 0.06, 0.28]),
                              Box([0.0, 0.0, -0.05], [1.4, 1.4, 0.1]),
                              Sphere([0.3, 0.3, 0.3], 0.1),
                              Cylinder([-0.3, 0.2, 0.2], 0.05, 0.4),
                              Box([-0.3, -0.4, 0.3], [0.1, 0.2, 0.1])]),
        "17 obstacles": mixed_scene(17),
    }
    rng = np.random.default_rng(0)
    print(f"# {POINTS} points uniform in the scene bounds; grid at {CELL * 100:.0f} cm; medians")
    print(f"{'scene':26s} {'query':>8s} {'dist':>8s} | {'EDT build':>10s} {'exact build':>12s} "
          f"{'grid query':>10s} | {'break-even':>10s}")
    for label, scene in scenes.items():
        points = rng.uniform(scene.bounds[0], scene.bounds[1], (POINTS, 3))
        analytic = median_seconds(lambda: scene.query(points), 200)
        distance = median_seconds(lambda: scene.distance(points), 200)
        # from_obstacles: a fresh build each time (Scene.sdf would return its cached grid)
        edt = median_seconds(lambda: SignedDistanceField.from_obstacles(
            scene.obstacles, scene.bounds, CELL), 5)
        exact = median_seconds(lambda: SignedDistanceField.from_obstacles(
            scene.obstacles, scene.bounds, CELL, exact=True), 5)
        grid = scene.sdf(CELL)
        grid_query = median_seconds(lambda: grid.query(points), 200)
        # queries after which building the (cheaper) grid and querying it beats the analytic query
        saving = analytic - grid_query
        even = f"{min(edt, exact) / saving:10.0f}" if saving > 0 else f"{'never':>10s}"
        print(f"{label:26s} {analytic * 1e3:6.3f}ms {distance * 1e3:6.3f}ms | {edt * 1e3:8.1f}ms "
              f"{exact * 1e3:10.1f}ms {grid_query * 1e3:8.3f}ms | {even}")
    print("# query: Scene.query (distance + gradient); dist: Scene.distance; grid: "
          f"{scenes['1 obstacle (box_closing)'].sdf(CELL).shape} nodes for the default workspace")


if __name__ == "__main__":
    main()
