"""Report: obstacle-weighted vs unweighted priors learned from seeded cluttered demonstrations.

For box_closing, reach_from_above and two_target_press (10 demonstrations each lifting 8 cm
over a box of its own, seeds 0-2): the rms distance [mm] of each prior's mean from the
clutter-free demonstrations' mean (same seed), unweighted, weighted with the reference's
defaults (eps 0.3 m, sigma 0.001) and with eps 0.15 m, sigma 2.5e-4 (scaled to these ~0.4 m
skills), plus the effective number of demonstrations per step. Writes the side-by-side figure
of box_closing seed 0 to --out (default out/weighted_priors.png).

Run: python benchmarks/report_obstacle_weighting.py [--out PATH]
"""
from __future__ import annotations

import argparse

import numpy as np

from clamp import ObstacleWeighting, learn_prior
from clamp.prior.obstacle_weighting import demonstration_weights
from clamp.viz.prior_plots import plot_weighted_priors
from scenes import make_cluttered_demonstrations, make_demonstrations

SETTINGS = (("reference eps 0.3, sigma 1e-3", ObstacleWeighting()),
            ("scaled eps 0.15, sigma 2.5e-4", ObstacleWeighting(eps=0.15, sigma=0.00025)))


def rms_mm(prior, reference: np.ndarray) -> float:
    return 1e3 * float(np.sqrt(np.mean(np.sum((prior.position_mean - reference) ** 2, axis=1))))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/weighted_priors.png")
    args = parser.parse_args()
    print("rms distance of the prior mean from the clutter-free skill [mm] "
          "(min effective demos per step)")
    for skill in ("box_closing", "reach_from_above", "two_target_press"):
        for seed in range(3):
            demos = make_cluttered_demonstrations(skill, num_demos=10, seed=seed)
            reference = make_demonstrations(skill, num_demos=10, seed=seed).mean_position()
            row = f"{skill:17s} seed {seed}: unweighted {rms_mm(learn_prior(demos), reference):5.1f}"
            for label, weighting in SETTINGS:
                w = demonstration_weights(demos.positions, demos.obstacles, weighting)
                share = w / w.sum(axis=0)
                effective = float((1.0 / np.sum(share**2, axis=0)).min())
                prior = learn_prior(demos, obstacle_weighting=weighting)
                row += f" | {label} {rms_mm(prior, reference):5.1f} ({effective:.1f})"
            print(row)
    demos = make_cluttered_demonstrations("box_closing", num_demos=10, seed=0)
    weighting = SETTINGS[1][1]
    plot_weighted_priors(learn_prior(demos), learn_prior(demos, obstacle_weighting=weighting),
                         demos, weights=demonstration_weights(demos.positions, demos.obstacles,
                                                              weighting),
                         reference=make_demonstrations("box_closing", num_demos=10,
                                                       seed=0).mean_position(), path=args.out)
    print(f"figure: {args.out}")


if __name__ == "__main__":
    main()
