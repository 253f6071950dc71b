"""Learn a skill from demonstrations and plan it on a robot arm around a new obstacle.

Run: ``python examples/learn_and_plan.py`` (a few seconds).
"""
import numpy as np

from clamp import learn_prior, plan
from robots import load_robot
from scenes import Box, Scene, make_demonstrations

demos = make_demonstrations("box_closing", num_demos=6, num_points=100, seed=0)  # or load_demonstrations("x.mat")
prior = learn_prior(demos)                             # workspace prior: mean (T, 6), covariances
robot = load_robot("jaco")                             # registered arm (or Robot.from_urdf, see your_own_urdf.py)
start = prior.mean[0, :3] + [0.0, -0.03, 0.03]         # a new start, 4 cm from the demonstrated one [m]
free = plan(prior, robot, None, start)                 # empty scene first
middle = free.ee_path[len(free.ee_path) // 2]
scene = Scene([Box(middle - [0.0, 0.0, 0.02], [0.08, 0.08, 0.08])])  # a cube across that path
result = plan(prior, robot, scene, start)

print(f"success {result.success} {result.reasons}")
print(f"clearance {result.min_clearance * 1000:.1f} mm, start error {result.start_error * 1000:.3f} mm, "
      f"{result.iterations} iterations in {result.timings['total']:.2f} s")
print(f"joint path {result.q.shape}, end-effector path {result.ee_path.shape}, "
      f"largest posterior std {1000 * np.max(result.ee_std):.2f} mm")
