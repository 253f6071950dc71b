"""CLAMP planning with the TLGC boundary factor: does the plan stay inside the cylinder?

One skill's synthetic demonstrations give both a CLAMP workspace prior and a generalized
cylinder. The Jaco reproduces the skill from a start inside the first cross-section towards a
goal moved ``goal_offset`` metres outside the last cross-section's boundary. Without the
boundary factor the planner spreads the goal's pull back along the whole path and leaves the
demonstrated region early; with it the path stays inside the cylinder until the goal forces
it out. The fractions of support states whose end-effector position lies inside (within
1 mm of) the matching cross-section are printed for both plans.

Run: ``python -m tlgc.demo_clamp_cylinder [--skill NAME] [--robot jaco|sawyer]``.
"""
from __future__ import annotations

import argparse
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from skillplan.command_line import (EXIT_FAILED, EXIT_OK, CommandLineParser, integer_at_least, number,
                                 quiet, run)

from .boundary_factor import BoundaryFamily, boundary_distance, section_indices
from .cylinder import GeneralizedCylinder, fit_cylinder
from .errors import TLGCArgumentError
from clamp import learn_prior, plan
from robots import load_robot
from scenes import make_demonstrations

INSIDE_TOLERANCE = 1e-3      # [m] counted as inside when at most this far outside


@dataclass(frozen=True)
class ClampCylinderDemo:
    """Plans without / with the boundary factor (clamp PlanResult), the cylinder, the goal (3,),
    per-state distances outside the boundary (T,) [m] and the inside fractions."""

    without_factor: Any
    with_factor: Any
    cylinder: GeneralizedCylinder
    goal: np.ndarray
    outside_without: np.ndarray
    outside_with: np.ndarray

    @property
    def fraction_inside_without(self) -> float:
        return float(np.mean(self.outside_without <= INSIDE_TOLERANCE))

    @property
    def fraction_inside_with(self) -> float:
        return float(np.mean(self.outside_with <= INSIDE_TOLERANCE))


def outside_distances(cylinder: GeneralizedCylinder, ee_path: np.ndarray) -> np.ndarray:
    """Distance [m] outside the boundary (T,) of an end-effector path (T,3), state i in
    cross-section round(i / (T-1) (N-1)) (negative inside)."""
    k = section_indices(np.arange(len(ee_path)), len(ee_path), cylinder.num_sections)
    return boundary_distance(cylinder, k, ee_path).distance


def run_clamp_cylinder_demo(skill: str = "reach_from_above", robot_name: str = "jaco",
                            num_states: int = 40, goal_offset: float = 0.05,
                            jitter: float = 1e-4, sigma: float = 0.005, margin: float = 0.0,
                            start_ratio: float = 0.3, seed: int = 0,
                            config: Any = None,
                            start_shrinkage: str | float = "auto") -> ClampCylinderDemo:
    """Plan the skill twice (without / with :class:`BoundaryFamily`) and compare.

    num_states T support states (demonstrations resampled to T, same total duration as the
    250-step reference); goal_offset [m] beyond the last boundary along its normal; jitter is
    added to the learned prior's covariances (a softer prior lets the goal pull the plan);
    sigma [m], margin [m] of the boundary factor; start at ``start_ratio`` of the first
    boundary along its normal; config: a clamp.PlannerConfig for both plans (None: defaults);
    start_shrinkage: the learner's (clamp.learn_prior; "auto" by default).
    """

    if not 0.0 <= start_ratio < 1.0:
        raise TLGCArgumentError(f"start_ratio: expected a number in [0, 1), got {start_ratio!r}")
    demos = make_demonstrations(skill, num_demos=6, num_points=num_states,
                                dt=0.16 * 250 / num_states, seed=seed)
    prior = learn_prior(demos, jitter=jitter, start_shrinkage=start_shrinkage)
    cylinder = fit_cylinder(demos, "spline")
    robot = load_robot(robot_name)
    start = cylinder.directrix[0] + start_ratio * cylinder.radius(0, 0.0) * cylinder.normals[0]
    end_radius = float(cylinder.radius(cylinder.num_sections - 1, 0.0))
    goal = cylinder.directrix[-1] + (end_radius + goal_offset) * cylinder.normals[-1]
    plain = plan(prior, robot, None, start, goal=goal, config=config)
    bounded = plan(prior, robot, None, start, goal=goal, config=config,
                   extra_factors=[BoundaryFamily(cylinder, num_states, margin=margin,
                                                  sigma=sigma)])
    return ClampCylinderDemo(plain, bounded, cylinder, goal,
                             outside_distances(cylinder, plain.ee_path),
                             outside_distances(cylinder, bounded.ee_path))


def report(args: argparse.Namespace) -> int:
    """Run the demo and print the inside fractions (exit 0 when both plans succeed, else 1)."""
    demo = run_clamp_cylinder_demo(args.skill, args.robot, args.states, args.goal_offset)
    for label, result, outside, inside in (
            ("without boundary factor", demo.without_factor, demo.outside_without,
             demo.fraction_inside_without),
            ("with boundary factor", demo.with_factor, demo.outside_with, demo.fraction_inside_with)):
        if not quiet(args):
            print(f"{label:>24}: {inside * 100:5.1f} % of {len(outside)} support states inside the "
                  f"cylinder, farthest outside {outside.max() * 1000:6.1f} mm, goal error "
                  f"{(result.goal_error or 0.0) * 1000:5.1f} mm, success {result.success}, "
                  f"{result.timings['total']:.2f} s")
    return EXIT_OK if demo.with_factor.success else EXIT_FAILED


def main(argv: Sequence[str] | None = None) -> int:
    """Command line; bad input: one line on stderr, exit 2."""
    parser = CommandLineParser(prog="python -m tlgc.demo_clamp_cylinder",
                               description=__doc__.split("\n\n")[0])
    parser.add_argument("--skill", default="reach_from_above", help="synthetic skill (scenes.SKILLS)")
    parser.add_argument("--robot", default="jaco", help="registered robot (jaco, sawyer)")
    parser.add_argument("--states", type=integer_at_least(2), default=40, help="support states T")
    parser.add_argument("--goal-offset", type=number, default=0.05,
                        help="goal distance outside the last cross-section [m]")
    parser.set_defaults(run=report)
    return run(parser, argv)


if __name__ == "__main__":
    raise SystemExit(main())
