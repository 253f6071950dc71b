"""A CLAMP plan kept inside a TLGC cylinder by the boundary factor (your own factor family too).

The goal lies 5 cm outside the cylinder's last cross-section. Without the boundary factor the
planner spreads the goal's pull along the whole path and leaves the demonstrated region early;
with it the path stays inside until the goal forces it out.
Run: ``python examples/boundary_factor.py`` (a few seconds).
"""
import numpy as np

from clamp import learn_prior, plan
from robots import load_robot
from scenes import make_demonstrations
from tlgc import BoundaryFamily, fit_cylinder
from tlgc.demo_clamp_cylinder import outside_distances

T = 40                                                   # support states
demos = make_demonstrations("reach_from_above", num_demos=6, num_points=T, dt=0.16 * 250 / T, seed=0)
prior = learn_prior(demos, jitter=1e-4)                  # a softer prior lets the goal pull
cylinder = fit_cylinder(demos, "spline")
start = cylinder.directrix[0] + 0.3 * cylinder.radius(0, 0.0) * cylinder.normals[0]
goal = cylinder.directrix[-1] + (cylinder.radius(cylinder.num_sections - 1, 0.0) + 0.05) * cylinder.normals[-1]
robot = load_robot("jaco")
for label, extra in (("without", []), ("with", [BoundaryFamily(cylinder, T, sigma=0.005)])):
    result = plan(prior, robot, None, start, goal=goal, extra_factors=extra)
    outside = outside_distances(cylinder, result.ee_path)  # (T,) [m], negative inside
    print(f"{label:>7} boundary factor: {100 * np.mean(outside <= 1e-3):5.1f} % of states inside, "
          f"goal error {1000 * result.goal_error:.1f} mm, success {result.success}")
