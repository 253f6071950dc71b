"""Plan box_closing around its box on both arms, export the executable trajectory and retime it.

For the Jaco and the Sawyer (demonstrations and box moved into the Sawyer's reach): plan,
export the plan with its own timing, check it against the URDF's velocity limits and an
acceleration limit, and export it executable (the default of ``to_joint_trajectory``: retimed by
TOPP-RA, the fastest execution within the limits, from rest to rest); write the planned one
(JSON), the retimed one (JSON, CSV and the ROS 2 JointTrajectory message) and load back. Uses
../shared/datasets/box_closing.mat when present, else the synthetic skill.
Run: ``python examples/export_and_retime.py [OUT_DIR]`` (about ten seconds).
"""
import sys
import tempfile
from pathlib import Path

import numpy as np

from clamp import learn_prior, plan
from robots import JointTrajectory, check_limits, load_robot
from scenes import Scene, builtin_scene, load_demonstrations, make_demonstrations, shared_dataset

out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp())
out.mkdir(parents=True, exist_ok=True)
path = shared_dataset("box_closing")
demos = load_demonstrations(path) if path else make_demonstrations("box_closing", seed=0)
ACCELERATION_LIMIT = 1.5                                  # [rad/s^2]: URDFs carry none
for name, offset in (("jaco", [0.0, 0.0, 0.0]), ("sawyer", [0.3, 0.0, 0.2])):
    robot = load_robot(name)
    prior = learn_prior(demos.translated(np.array(offset)))
    scene = Scene([box.translated(np.array(offset)) for box in builtin_scene("box_closing").obstacles])
    result = plan(prior, robot, scene, start=prior.mean[0, :3])
    trajectory = result.to_joint_trajectory(robot, retime=False)  # the plan's own timing
    before = check_limits(trajectory, robot.velocity_limits, ACCELERATION_LIMIT)
    retimed = result.to_joint_trajectory(robot, acceleration_limits=ACCELERATION_LIMIT)  # executable
    report = retimed.verdict["retiming"]
    trajectory.to_json(out / f"{name}_plan.json", overwrite=True)
    retimed.to_json(out / f"{name}_retimed.json", overwrite=True)
    retimed.to_csv(out / f"{name}_retimed.csv", overwrite=True)
    retimed.to_ros2_json(out / f"{name}_retimed_ros2.json", overwrite=True)
    again = JointTrajectory.load(out / f"{name}_retimed.json")
    assert np.array_equal(again.positions, retimed.positions)  # the round trip is exact
    print(f"{name}: plan success {result.success}, clearance {1000 * result.min_clearance:.0f} mm; "
          f"limits {'met' if before.within_limits else 'violated'} before retiming; "
          f"{report['method']}: {report['duration_before']:.2f} s -> {report['duration_after']:.2f} s, "
          f"within limits {report['within_limits']}, path deviation {1000 * report['max_ee_deviation']:.3f} mm")
print(f"wrote {out}")
