"""Command line: fit collision spheres to a built-in robot or to any URDF arm, as the planner does.

``python -m robots.sphere_cli --robot NAME`` (written to robots/spheres/NAME.json unless
--out is given) or ``python -m robots.sphere_cli --urdf PATH --end-effector FRAME --out FILE
[--package-dir DIR]``. The fit is the planner's own (:meth:`robots.Robot.fit_spheres`, through
the sphere cache): the links that move the end effector, fingers and tools beyond it locked
onto it, as ``clamp plan --urdf PATH --end-effector FRAME`` fits them. An existing --out file
is replaced only with --force; the file is written atomically. Bad input: one line on stderr,
exit 2 (:mod:`skillplan.command_line`). Kept apart from :mod:`robots.spheres` so the fitting
library does not import the registry (no import cycle).
"""
from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence

from skillplan.command_line import (EXIT_OK, CommandLineParser, integer_at_least, number, output_file,
                                    quiet, run)

from .errors import RobotError, URDFParseError
from .registry import load_robot, sphere_override_path
from .robot import Robot
from .sphere_model import save_sphere_file
from .spheres import INFLATION, MAX_SPHERES, sphere_coverage
from .validation import as_file


def fit(args: argparse.Namespace) -> int:
    """Fit, write and report the spheres of ``args`` (see :func:`parser`)."""
    if args.robot is not None:
        if args.end_effector is not None:
            raise RobotError("--end-effector: only with --urdf (a built-in robot has its own end effector)")
        robot = load_robot(args.robot)
        out = output_file(args.out, args.force) if args.out else sphere_override_path(args.robot)
    else:
        if args.out is None:
            raise RobotError("--out: required with --urdf (the sphere file to write)")
        out = output_file(args.out, args.force)
        robot = _urdf_robot(args)
    start = time.perf_counter()
    spheres = robot.fit_spheres(args.links, args.max_spheres, args.inflation, args.seed)
    seconds = time.perf_counter() - start
    save_sphere_file(spheres, out)
    geometry, _ = robot.fitting_geometry()
    report = sphere_coverage(robot.model, geometry, spheres, args.inflation, links=args.links)
    if not quiet(args):
        print(f"{out}: {spheres.count} spheres in {seconds:.1f} s, coverage {report.coverage:.4f} at "
              f"{args.inflation} m inflation, mean radius {report.mean_radius:.4f} m, "
              f"mean overshoot {report.mean_overshoot:.4f} m")
    return EXIT_OK


def _urdf_robot(args: argparse.Namespace) -> Robot:
    """The arm of --urdf / --end-effector / --package-dir, as ``clamp plan --urdf`` loads it; errors
    name the option."""
    as_file(args.urdf, "--urdf", URDFParseError)
    if args.end_effector is None:
        raise RobotError(f"--end-effector: required with --urdf {args.urdf}: the frame the planner plans for "
                         "(as in clamp plan --urdf FILE --end-effector FRAME); the spheres are fitted to "
                         "the links that move it, as the planner fits them")
    try:
        robot = Robot.from_urdf(args.urdf, args.end_effector, package_dirs=args.package_dir)
        robot.collision_model    # a mesh not found: one line naming it, with the --package-dir hint
    except URDFParseError as exc:
        raise URDFParseError(f"--urdf: {str(exc).removeprefix('path: ')}") from None
    return robot


def parser() -> argparse.ArgumentParser:
    """Arguments: --robot NAME | --urdf PATH --out FILE, and the fitting settings."""
    p = CommandLineParser(prog="python -m robots.sphere_cli",
                          description="Fit collision spheres to a built-in robot (--robot NAME, written "
                                      "to its sphere file robots/spheres/NAME.json unless --out is given) "
                                      "or to any URDF arm (--urdf PATH --end-effector FRAME --out FILE), "
                                      "as the planner fits them.")
    source = p.add_mutually_exclusive_group(required=True)
    source.add_argument("--robot", help="built-in robot name (jaco, sawyer)")
    source.add_argument("--urdf", help="URDF file (with --end-effector and --out)")
    p.add_argument("--end-effector", default=None, metavar="FRAME",
                   help="with --urdf: the frame the planner plans for (clamp plan's --end-effector); "
                        "the spheres cover the links that move it")
    p.add_argument("--out", help="sphere file to write (JSON)")
    p.add_argument("--force", action="store_true", help="replace an existing --out file")
    p.add_argument("--package-dir", action="append", default=[], metavar="DIR",
                   help="with --urdf: folder that holds package:// meshes (repeatable)")
    p.add_argument("--links", nargs="*", default=None, help="links to cover (default: all moving links)")
    p.add_argument("--max-spheres", type=integer_at_least(1), default=MAX_SPHERES,
                   help=f"sphere budget (default {MAX_SPHERES}, the planner's)")
    p.add_argument("--inflation", type=number, default=INFLATION,
                   help=f"allowed growth [m] (default {INFLATION}, the planner's)")
    p.add_argument("--seed", type=integer_at_least(0), default=0)
    p.set_defaults(run=fit)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Command line; returns the exit code (0 written, 2 bad input)."""
    return run(parser(), argv)


if __name__ == "__main__":
    sys.exit(main())
