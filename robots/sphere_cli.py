"""Command line: fit collision spheres to a built-in robot or to any URDF.

``python -m robots.sphere_cli --robot NAME`` (written to robots/spheres/NAME.json unless
--out is given) or ``python -m robots.sphere_cli --urdf PATH --out FILE``. An existing --out
file is replaced only with --force; the file is written atomically. Bad input: one line on
stderr, exit 2 (:mod:`skillplan.command_line`). Kept apart from :mod:`robots.spheres` so the
fitting library does not import the registry (no import cycle).
"""
from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from skillplan.command_line import (EXIT_OK, CommandLineParser, integer_at_least, native_stderr_logged,
                                 number, output_file, quiet, run)

from .errors import RobotError, URDFParseError
from .registry import load_robot, sphere_override_path
from .sphere_model import save_sphere_file
from .spheres import fit_spheres, sphere_coverage


def fit(args: argparse.Namespace) -> int:
    """Fit, write and report the spheres of ``args`` (see :func:`parser`)."""
    if args.robot is not None:
        robot = load_robot(args.robot)
        model, collision_model = robot.model, robot.collision_model
        out = output_file(args.out, args.force) if args.out else sphere_override_path(args.robot)
    else:
        if args.out is None:
            raise RobotError("--out: required with --urdf (the sphere file to write)")
        out = output_file(args.out, args.force)
        model, collision_model = _urdf_models(args.urdf, args.package_dir)
    start = time.perf_counter()
    spheres = fit_spheres(model, collision_model, args.links, args.max_spheres, args.inflation, args.seed)
    seconds = time.perf_counter() - start
    save_sphere_file(spheres, out)
    report = sphere_coverage(model, collision_model, spheres, args.inflation, links=args.links)
    if not quiet(args):
        print(f"{out}: {spheres.count} spheres in {seconds:.1f} s, coverage {report.coverage:.4f} at "
              f"{args.inflation} m inflation, mean radius {report.mean_radius:.4f} m, "
              f"mean overshoot {report.mean_overshoot:.4f} m")
    return EXIT_OK


def _urdf_models(urdf: str, package_dirs: list[str]):
    """Kinematic and collision models of a URDF file (URDFParseError if missing or invalid)."""
    import pinocchio as pin
    if not Path(urdf).is_file():
        raise URDFParseError(f"--urdf: URDF file {urdf!r} does not exist")
    try:
        with native_stderr_logged():
            model, collision_model, _ = pin.buildModelsFromUrdf(str(urdf), package_dirs=package_dirs)
    except Exception as exc:  # Pinocchio raises bare RuntimeErrors
        raise URDFParseError(f"--urdf: cannot load {urdf!r} (package dirs {package_dirs}): "
                             f"{' '.join(str(exc).split())}") from exc
    return model, collision_model


def parser() -> argparse.ArgumentParser:
    """Arguments: --robot NAME | --urdf PATH --out FILE, and the fitting settings."""
    p = CommandLineParser(prog="python -m robots.sphere_cli",
                          description="Fit collision spheres to a built-in robot (--robot NAME, written "
                                      "to its sphere file robots/spheres/NAME.json unless --out is given) "
                                      "or to any URDF (--urdf PATH --out FILE).")
    source = p.add_mutually_exclusive_group(required=True)
    source.add_argument("--robot", help="built-in robot name (jaco, sawyer)")
    source.add_argument("--urdf", help="URDF file")
    p.add_argument("--out", help="sphere file to write (JSON)")
    p.add_argument("--force", action="store_true", help="replace an existing --out file")
    p.add_argument("--package-dir", action="append", default=[], help="folder that holds package:// paths")
    p.add_argument("--links", nargs="*", default=None, help="links to cover (default: all moving links)")
    p.add_argument("--max-spheres", type=integer_at_least(1), default=40)
    p.add_argument("--inflation", type=number, default=0.01, help="allowed growth in metres")
    p.add_argument("--seed", type=integer_at_least(0), default=0)
    p.set_defaults(run=fit)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Command line; returns the exit code (0 written, 2 bad input)."""
    return run(parser(), argv)


if __name__ == "__main__":
    sys.exit(main())
