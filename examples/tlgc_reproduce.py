"""TLGC: fit a generalized cylinder to demonstrations and reproduce the skill from new starts.

Run: ``python examples/tlgc_reproduce.py`` (under a second).
"""
import numpy as np

from scenes import make_demonstrations
from tlgc import fit_cylinder, random_starts, reproduce

demos = make_demonstrations("pick_place", num_demos=5, num_points=200, seed=0)
cylinder = fit_cylinder(demos, cross_section="spline")   # or "circle", "ellipse"
starts = random_starts(cylinder, 100, np.random.default_rng(0))  # (100, 3) inside the first cross-section
paths = reproduce(cylinder, starts, eta_final=0.0)       # (100, N, 3); eta_final 0: converge to the directrix
ratio = cylinder.ratio(paths, np.arange(cylinder.num_sections)[None, :])  # <= 1 inside the cylinder
print(f"{cylinder.num_sections} cross-sections, {len(paths)} reproductions of shape {paths.shape[1:]}")
print(f"points inside the cylinder {100 * np.mean(ratio <= 1 + 1e-9):.1f} %, "
      f"end distance to the directrix {1000 * np.abs(paths[:, -1] - cylinder.directrix[-1]).max():.2f} mm")
