"""Collision-sphere report for the built-in robots: sphere count, coverage at 1 cm inflation, fit time.

Usage: python benchmarks/sphere_report.py [--robots jaco sawyer] [--repeats 3] [--plot DIR]

For each robot it fits spheres (seed 0, at most 40, 1 cm inflation) `repeats` times and prints the
median fitting time, then the coverage of those spheres and of the stored sphere file
robots/spheres/<name>.json, measured on 20000 fresh surface samples. With --plot it writes
DIR/spheres_<name>.png: every link's surface samples and spheres in the link's principal planes.
"""
from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from robots import load_robot  # noqa: E402
from robots.collision_geometry import link_surfaces  # noqa: E402
from robots.registry import sphere_override_path  # noqa: E402
from robots.sphere_model import SphereModel, load_sphere_file  # noqa: E402
from robots.spheres import fit_spheres, sphere_coverage  # noqa: E402

INFLATION = 0.01


def _row(label: str, spheres: SphereModel, model, geometry, seconds: float | None) -> str:
    report = sphere_coverage(model, geometry, spheres, inflation=INFLATION, samples=20000, rng=12345)
    timing = f"{seconds:7.2f}" if seconds is not None else "      -"
    worst = int(np.argmin(report.link_coverage))
    return (f"{label:<16} {spheres.count:>7d} {report.coverage:>9.4f} {report.link_coverage[worst]:>9.4f} "
            f"{report.max_gap * 1e3:>7.2f} {report.mean_radius * 1e3:>8.1f} {report.max_radius * 1e3:>7.1f} "
            f"{report.mean_overshoot * 1e3:>9.1f} {report.max_overshoot * 1e3:>8.1f} {timing}")


def _plot(name: str, spheres: SphereModel, model, geometry, out: Path) -> Path:
    surfaces = link_surfaces(model, geometry)
    rng = np.random.default_rng(0)
    fig, axes = plt.subplots(2, len(surfaces), figsize=(2.8 * len(surfaces), 5.6), squeeze=False)
    for column, surface in enumerate(surfaces):
        points = surface.sample_surface(4000, rng)
        centres, radii = spheres.for_link(surface.link_name)
        mean = points.mean(axis=0)
        axes_rows = np.linalg.svd(points - mean, full_matrices=False)[2]
        p, c = (points - mean) @ axes_rows.T, (centres - mean) @ axes_rows.T
        for row, (a, b) in enumerate([(0, 1), (0, 2)]):
            ax = axes[row, column]
            ax.scatter(p[:, a], p[:, b], s=0.2, c="k")
            for centre, radius in zip(c, radii):
                ax.add_patch(plt.Circle((centre[a], centre[b]), radius, fill=False, color="tab:red", lw=0.7))
                ax.add_patch(plt.Circle((centre[a], centre[b]), radius + INFLATION, fill=False, color="tab:blue",
                                        lw=0.4, ls="--"))
            ax.set_aspect("equal")
            ax.set_title(f"{surface.link_name} ({len(radii)})", fontsize=7)
            ax.tick_params(labelsize=6)
    fig.suptitle(f"{name}: {spheres.count} spheres (red) and grown by {INFLATION * 100:.0f} cm (blue), "
                 "principal planes of each link [m]", fontsize=9)
    fig.tight_layout()
    path = out / f"spheres_{name}.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="+", default=["jaco", "sawyer"])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--plot", type=Path, default=None, help="folder for per-link PNG figures")
    args = parser.parse_args()
    print(f"coverage = fraction of the collision surface within {INFLATION * 100:.0f} cm of a sphere; "
          "gap = worst miss; overshoot = distance from the sphere union's surface to the geometry")
    print(f"{'':<16} {'spheres':>7} {'coverage':>9} {'worst lnk':>9} {'gap mm':>7} {'mean r mm':>8} "
          f"{'max r mm':>7} {'overshoot':>9} {'p95 mm':>8} {'fit s':>7}")
    for name in args.robots:
        robot = load_robot(name)
        model, geometry = robot.model, robot.collision_model
        times, spheres = [], None
        for _ in range(args.repeats):
            start = time.perf_counter()
            spheres = fit_spheres(model, geometry, max_spheres=40, inflation=INFLATION, rng=0)
            times.append(time.perf_counter() - start)
        print(_row(f"{name} fitted", spheres, model, geometry, statistics.median(times)))
        stored = sphere_override_path(name)
        if stored.is_file():
            print(_row(f"{name} file", load_sphere_file(stored), model, geometry, None))
        if args.plot is not None:
            args.plot.mkdir(parents=True, exist_ok=True)
            print(f"  wrote {_plot(name, spheres, model, geometry, args.plot)}")


if __name__ == "__main__":
    main()
