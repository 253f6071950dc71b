"""Plan on any URDF arm: here the UR5 of example-robot-data, which the project does not register.

Run: ``python examples/your_own_urdf.py [URDF END_EFFECTOR_FRAME [PACKAGE_DIR]]`` (default: the UR5;
collision spheres are fitted from the URDF's collision meshes on first use, a few seconds).
"""
import sys

from clamp import learn_prior, plan
from robots import Robot
from robots.registry import example_robot_data_share
from scenes import Box, Scene, make_demonstrations

if len(sys.argv) > 2:                                    # your arm: URDF FRAME [PACKAGE_DIR ...]
    urdf, end_effector, package_dirs = sys.argv[1], sys.argv[2], sys.argv[3:]
else:                                                    # the UR5 (package:// root: share/)
    share = example_robot_data_share()
    urdf = share / "example-robot-data/robots/ur_description/urdf/ur5_joint_limited_robot.urdf"
    end_effector, package_dirs = "tool0", [share]
robot = Robot.from_urdf(urdf, end_effector=end_effector, package_dirs=package_dirs)
print(f"{robot.name}: {robot.n} joints {list(robot.joint_names)}, end effector {end_effector!r}")

demos = make_demonstrations("box_closing", num_points=60, seed=0)
prior = learn_prior(demos)
scene = Scene([Box([0.55, 0.25, 0.2], [0.1, 0.1, 0.1])])  # the spheres are fitted for this check
result = plan(prior, robot, scene, start=prior.mean[0, :3])
print(f"success {result.success} {result.reasons}; {len(robot.spheres.radii)} collision spheres, "
      f"clearance {result.min_clearance * 1000:.0f} mm, start error {result.start_error * 1000:.3f} mm")
