"""Command line: ``tlgc fit-reproduce`` fits a generalized cylinder and reproduces from it.

Example::

    tlgc fit-reproduce --demos ../shared/datasets/pick_place.mat --cross-section spline \\
        --out out/pick_place --count 10 --eta-final 0

writes cylinder.npz, reproductions.npy (R, N, 3), cylinder.png (3-D) and cross_sections.png,
and prints fit/reproduction times and the fraction of reproduced points inside the cylinder.
``--skill NAME`` uses the project's synthetic demonstrations instead of a file. The output
folder must be new or empty unless ``--force``; files are written atomically. Bad input: one
line on stderr, exit 2 (:mod:`skillplan.command_line`).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Sequence

import numpy as np

from skillplan.command_line import (EXIT_OK, CommandLineParser, atomic_write, integer_at_least,
                                 number, output_directory, quiet, run)
from scenes.errors import DemonstrationFileError
from skillplan.validation import as_file

from .cross_sections import CROSS_SECTION_TYPES
from .cylinder import fit_cylinder
from .errors import TLGCArgumentError
from .plots import plot_cross_sections, plot_cylinder, save_figure
from .reproduction import DEFAULT_GAMMA, random_starts, reproduce
import scenes


def _load(args: argparse.Namespace):

    if args.demos is not None:
        return scenes.load_demonstrations(args.demos)
    return scenes.make_demonstrations(args.skill, num_demos=args.num_demos, seed=args.seed)


def fit_reproduce(args: argparse.Namespace) -> int:
    """Run the fit-reproduce command; returns the exit status."""
    if args.demos is not None:      # named as the user typed it, before the output folder is made
        as_file(args.demos, "--demos", DemonstrationFileError)
    out = output_directory(args.out, args.force)
    demos = _load(args)
    t0 = time.perf_counter()
    cyl = fit_cylinder(demos, args.cross_section, num_points=args.num_points)
    t_fit = time.perf_counter() - t0
    starts = random_starts(cyl, args.count, rng=args.seed)
    t0 = time.perf_counter()
    reps = reproduce(cyl, starts, eta_final=args.eta_final, gamma=args.gamma)
    t_rep = time.perf_counter() - t0
    inside = cyl.ratio(reps, np.arange(cyl.num_sections)[None, :]) <= 1.0 + 1e-9
    if args.sections > cyl.num_sections:
        raise TLGCArgumentError(f"--sections: expected at most the {cyl.num_sections} "
                                   f"cross-sections of the cylinder, got {args.sections}")

    atomic_write(out / "cylinder.npz", cyl.save, overwrite=True)
    atomic_write(out / "reproductions.npy", lambda handle: np.save(handle, reps), overwrite=True)
    name = getattr(demos, "name", "") or (Path(args.demos).stem if args.demos else args.skill)
    save_figure(plot_cylinder(cyl, reps, title=f"{name}: {cyl.cross_section} cylinder, "
                                               f"{args.count} reproductions"), out / "cylinder.png")
    indices = np.linspace(0, cyl.num_sections - 1, args.sections).round().astype(int)
    save_figure(plot_cross_sections(cyl, indices, reps), out / "cross_sections.png")
    if not quiet(args):
        print(f"{name}: M={len(cyl.effective_points)} N={cyl.num_sections} "
              f"cross-section={cyl.cross_section}")
        print(f"fit {1e3 * t_fit:.1f} ms, {args.count} reproductions {1e3 * t_rep:.1f} ms, "
              f"points inside {100.0 * inside.mean():.2f} %")
        print(f"wrote {out}/cylinder.npz, reproductions.npy, cylinder.png, cross_sections.png")
    return EXIT_OK


def build_parser() -> argparse.ArgumentParser:
    """Argument parser with one sub-command per task."""
    parser = CommandLineParser(prog="tlgc", description="Skill learning with generalized cylinders")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    fr = commands.add_parser("fit-reproduce", help="fit a cylinder, reproduce from random starts, plot")
    source = fr.add_mutually_exclusive_group(required=True)
    source.add_argument("--demos", help="demonstration file (.mat CLAMP/TLGC, .npz, .csv)")
    source.add_argument("--skill", help="synthetic skill name (scenes.SKILLS)")
    fr.add_argument("--num-demos", type=integer_at_least(2), default=5,
                    help="demonstrations for --skill (default 5)")
    fr.add_argument("--cross-section", default="spline", choices=sorted(CROSS_SECTION_TYPES))
    fr.add_argument("--num-points", type=integer_at_least(2), default=None,
                    help="resample to N points")
    fr.add_argument("--out", required=True, help="output folder (new or empty unless --force)")
    fr.add_argument("--force", action="store_true", help="replace files in a non-empty --out")
    fr.add_argument("--count", type=integer_at_least(1), default=10,
                    help="number of reproductions (default 10)")
    fr.add_argument("--eta-final", type=number, default=None,
                    help="target ratio (0 convergent, 1 divergent; default: fixed ratio)")
    fr.add_argument("--gamma", type=number, default=DEFAULT_GAMMA, help="decay constant of eq. 10")
    fr.add_argument("--seed", type=integer_at_least(0), default=0, help="seed of the random starts")
    fr.add_argument("--sections", type=integer_at_least(1), default=8,
                    help="cross-sections to draw (default 8)")
    fr.set_defaults(run=fit_reproduce)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``tlgc`` command; bad input prints one error line, exit status 2."""
    return run(build_parser(), argv)


if __name__ == "__main__":
    sys.exit(main())
