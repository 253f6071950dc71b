"""Command line: fit collision spheres to a built-in robot or to any URDF.

``python -m robots.sphere_cli --robot NAME`` (written to robots/spheres/NAME.json unless
--out is given) or ``python -m robots.sphere_cli --urdf PATH --out FILE``. Kept apart from
:mod:`robots.spheres` so the fitting library does not import the registry (no import cycle).
"""
from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence

import pinocchio as pin

from .registry import load_robot, sphere_override_path
from .sphere_model import save_sphere_file
from .spheres import fit_spheres, sphere_coverage


def main(argv: Sequence[str] | None = None) -> int:
    """Command line: fit spheres to a built-in robot (--robot NAME, written to its sphere file
    robots/spheres/NAME.json unless --out is given) or to any URDF (--urdf PATH --out FILE)."""
    parser = argparse.ArgumentParser(prog="python -m robots.sphere_cli", description=main.__doc__)
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--robot", help="built-in robot name (jaco, sawyer)")
    source.add_argument("--urdf", help="URDF file")
    parser.add_argument("--out", help="sphere file to write (JSON)")
    parser.add_argument("--package-dir", action="append", default=[], help="folder that holds package:// paths")
    parser.add_argument("--links", nargs="*", default=None, help="links to cover (default: all moving links)")
    parser.add_argument("--max-spheres", type=int, default=40)
    parser.add_argument("--inflation", type=float, default=0.01, help="allowed growth in metres")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    if args.robot is not None:
        robot = load_robot(args.robot)
        model, collision_model = robot.model, robot.collision_model
        out = args.out or sphere_override_path(args.robot)
    else:
        if args.out is None:
            parser.error("--out is required with --urdf")
        model, collision_model, _ = pin.buildModelsFromUrdf(args.urdf, package_dirs=args.package_dir)
        out = args.out
    start = time.perf_counter()
    spheres = fit_spheres(model, collision_model, args.links, args.max_spheres, args.inflation, args.seed)
    seconds = time.perf_counter() - start
    save_sphere_file(spheres, out)
    report = sphere_coverage(model, collision_model, spheres, args.inflation, links=args.links)
    print(f"{out}: {spheres.count} spheres in {seconds:.1f} s, coverage {report.coverage:.4f} at "
          f"{args.inflation} m inflation, mean radius {report.mean_radius:.4f} m, "
          f"mean overshoot {report.mean_overshoot:.4f} m")
    return 0


if __name__ == "__main__":
    sys.exit(main())
